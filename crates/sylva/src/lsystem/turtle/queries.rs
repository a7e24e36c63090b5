//! cpfg's query modules (`?P`, `?H`, `?U`, `?L`) answered from a turtle run over the
//! string, and the communication modules `?E` answered by an environmental program
//! (Mech2004, Mech1996).

use super::run::run;
use super::{QueryState, TurtleOptions};
use crate::lsystem::environment::{Environment, Sensor};
use crate::lsystem::parse::Symbols;
use crate::lsystem::source::{ErrorKind, LsystemError, Source};
use crate::lsystem::string::ModuleString;

/// Answers cpfg's query modules (`?P` position, `?H` heading, `?U` up, `?L` left): runs
/// the turtle over `string` and writes the turtle's state at each query module into its
/// parameters (x, y, z, as many as the module has), in cpfg's coordinates (sylva's
/// (x, y, z) is cpfg's (z, y, −x)). cpfg does this after every
/// derivation step, so productions can react to where a module is. With `env`, the
/// same run also collects the communication modules `?E` and lets the environmental
/// program answer them (their parameters are overwritten with its responses).
pub fn answer_queries(
    symbols: &Symbols,
    string: &mut ModuleString,
    opts: &TurtleOptions,
    source: &Source,
    env: Option<&Environment>,
) -> Result<(), Box<LsystemError>> {
    answer_queries_within(symbols, string, opts, source, env, u64::MAX).map(|_| ())
}

/// [`answer_queries`] whose environmental program may do at most `work` units of work
/// (neighbour tests); returns the work it did. Past the limit the error is a
/// [`ErrorKind::Budget`] naming the derivation's work budget.
pub fn answer_queries_within(
    symbols: &Symbols,
    string: &mut ModuleString,
    opts: &TurtleOptions,
    source: &Source,
    env: Option<&Environment>,
    work: u64,
) -> Result<u64, Box<LsystemError>> {
    // The query pass draws the whole string: the node budget does not apply to it.
    let opts = &TurtleOptions { max_nodes: usize::MAX, ..opts.clone() };
    let cpfg_frame = opts.left == super::CPFG_LEFT;
    let names = ["?P", "?H", "?U", "?L", "?E"];
    let which: Vec<Option<usize>> =
        (0..symbols.len()).map(|i| names.iter().position(|n| *n == symbols.name(i as u16))).collect();
    if which.iter().all(|w| w.is_none() || (env.is_none() && *w == Some(4))) {
        return Ok(0);
    }
    // Reserved fallibly before the run (issue 39): a string of hundreds of millions of
    // query modules is an error naming the module budget, not an abort.
    let queries = string.syms.iter().filter(|&&s| which[s as usize].is_some()).count();
    let mut found: Vec<(usize, QueryState)> = Vec::new();
    let (mut at, mut sensors): (Vec<usize>, Vec<Sensor>) = (Vec::new(), Vec::new());
    let sensed = if env.is_some() { queries } else { 0 };
    if found.try_reserve_exact(queries).is_err()
        || at.try_reserve_exact(sensed).is_err()
        || sensors.try_reserve_exact(sensed).is_err()
    {
        return Err(source
            .error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "the string's {queries} query modules (`?P`, `?H`, `?U`, `?L`, `?E`) need more memory \
                     than is available to answer: {} bytes",
                    queries.saturating_mul(std::mem::size_of::<(usize, QueryState)>())
                ),
            )
            .with_help(
                "derive fewer steps (-n), or lower the module budget with --set generator.max_modules=N",
            ));
    }
    run(symbols, string, opts, source, &mut |_, _| {}, &mut |i, st| found.push((i, st)))?;
    // The `?E` modules: their indices in the string and what the environment sees.
    for (i, st) in found {
        let range = string.pofs[i] as usize..string.pofs[i + 1] as usize;
        match which[string.syms[i] as usize] {
            Some(4) if env.is_some() => {
                at.push(i);
                sensors.push(Sensor { position: st[0], values: string.params[range].to_vec() });
            }
            Some(4) => {}
            Some(k) => {
                // In cpfg's frame (issue 46 item 7): its (x, y, z) is sylva's (−z, y, x)
                // for L-systems (L = +Z here, −X in cpfg); strings already drawn in
                // cpfg's frame (`.str`, L = −X) answer as they are.
                let v = if cpfg_frame { st[k] } else { glam::DVec3::new(-st[k].z, st[k].y, st[k].x) };
                for (slot, c) in string.params[range].iter_mut().zip([v.x, v.y, v.z]) {
                    *slot = crate::lsystem::string::cpfg_param(c);
                }
            }
            None => {}
        }
    }
    let mut used = 0;
    if let Some(env) = env {
        used = env.respond_within(&mut sensors, work).map_err(|limit| {
            source.error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "the environmental program's work budget is used up: its {} sensors need more than {limit} \
                     neighbour tests (the derivation's work budget is left for them)",
                    sensors.len()
                ),
            )
        })?;
        for (&i, s) in at.iter().zip(sensors) {
            let range = string.pofs[i] as usize..string.pofs[i + 1] as usize;
            // The module keeps its arity: answers beyond it are dropped.
            for (slot, v) in string.params[range].iter_mut().zip(s.values) {
                *slot = crate::lsystem::string::cpfg_param(v);
            }
        }
    }
    Ok(used)
}
