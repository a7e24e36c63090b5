//! The random generators of a derivation (issue 46 item 9): sylva's portable one (PCG,
//! the default of sylva's own presets) and cpfg's, so that a stochastic cpfg model grows
//! the same plant as in cpfg.
//!
//! cpfg draws from two 48-bit linear congruential streams (POSIX `drand48`:
//! X' = (0x5DEECE66D·X + 0xB) mod 2⁴⁸, the draw X'/2⁴⁸; POSIX2017 `drand48`), as its
//! source does (AlgorithmicBotany/vlab `cpfg/`, read for the rules, no code copied):
//!
//! - the **expression stream** behind `ran`, `nran`, `bran` and `biran` (`erand48` on
//!   its own state) starts at X = 0x330E and is reseeded by `srand(s)` to
//!   X = (s mod 2³²)·2¹⁶ + 0x330E;
//! - the **choice stream** (`drand48`) picks stochastic productions. It is seeded only
//!   by the main L-system's `seed:` line, s ≠ 0, to X = 155·2³² + (s mod 2¹⁶)
//!   (`seed48({s, 0, 155})`); with `seed: 0` it keeps the C library's unseeded state,
//!   0 with glibc.
//!
//! `nran(m, σ)` is the polar method (Press1992 §7.2) with its second value kept for the
//! next call; cpfg starts with a kept value of 0, so the first `nran` before any
//! `srand` returns m exactly, and `srand` drops the kept value. `bran(a, b)` is Cheng's
//! algorithm BA (Cheng1978), `biran(n, p)` counts the n draws that are at most p.
//! How a derivation consumes the choice stream is in `derive/select.rs`.

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// Which generator a derivation draws from (recipe key `generator.random`; the
/// pipeline resolves its `auto` from where the recipe comes from).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RandomGenerator {
    /// sylva's portable generator (PCG 64), seeded by the derivation's seed; stochastic
    /// productions are weighed whenever the first matching one has a probability.
    #[default]
    Sylva,
    /// cpfg's two `drand48` streams, with cpfg's call order: an L-system is stochastic
    /// when it has a `seed:` line, and then every module of every step draws once.
    Cpfg {
        /// `None`: the model's own seeds (its `seed:` line, its `srand` calls) as in cpfg.
        /// `Some(n)`: as if the model's `seed:` line said n (the choice stream) and an
        /// `srand(n)` ran before its `Start:` block (the expression stream); a model's
        /// own `srand` calls still reseed the expression stream.
        seed: Option<u64>,
    },
}

impl RandomGenerator {
    /// Whether this is cpfg's generator.
    pub fn is_cpfg(self) -> bool {
        matches!(self, RandomGenerator::Cpfg { .. })
    }
}

const MASK48: u64 = (1 << 48) - 1;

/// One 48-bit linear congruential stream (POSIX `erand48`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lcg48 {
    /// The 48-bit state X.
    pub state: u64,
}

impl Lcg48 {
    /// A stream at state `x` (its low 48 bits).
    pub fn new(x: u64) -> Self {
        Lcg48 { state: x & MASK48 }
    }

    /// The next draw in [0, 1): the state advanced once, over 2⁴⁸ (exact in a double).
    pub fn draw(&mut self) -> f64 {
        self.state = 0x5_DEEC_E66D_u64.wrapping_mul(self.state).wrapping_add(0xB) & MASK48;
        self.state as f64 / (1u64 << 48) as f64
    }
}

/// cpfg's state after `srand(s)`: X = (s mod 2³²)·2¹⁶ + 0x330E.
fn srand_state(s: i64) -> u64 {
    ((s as u64 & 0xFFFF_FFFF) << 16) | 0x330E
}

/// cpfg's generator: the expression stream, the kept normal value, the choice stream.
#[derive(Debug, Clone, PartialEq)]
pub struct CpfgRandom {
    /// The expression stream (`ran`, `nran`, `bran`, `biran`; reseeded by `srand`).
    pub expr: Lcg48,
    /// The choice stream (stochastic productions; seeded by `seed:`).
    pub choice: Lcg48,
    /// `nran`'s kept second value, when it has one.
    kept: Option<f64>,
}

impl CpfgRandom {
    /// The state cpfg starts a run with: `file_seed` is the main L-system's `seed:` value
    /// (as cpfg's C `int`), `seed` the recipe's replacement ([`RandomGenerator::Cpfg`]).
    pub fn new(file_seed: Option<i64>, seed: Option<u64>) -> Self {
        let choice = match (seed, file_seed) {
            // `--seed n`: as if the file said `seed: n`; bits above cpfg's 16 fill the
            // state's other words, so larger seeds still differ (cpfg would drop them).
            (Some(0), _) => 0,
            (Some(n), _) => ((155 ^ (n >> 32)) & 0xFFFF) << 32 | (n & 0xFFFF_FFFF),
            (None, Some(s)) if s != 0 => 155 << 32 | (s as u64 & 0xFFFF),
            (None, _) => 0,
        };
        let (expr, kept) = match seed {
            // Before any `srand`, cpfg's kept normal value is its static's initial 0.
            None => (0x330E, Some(0.0)),
            Some(n) => (srand_state((n ^ (n >> 32)) as i64), None),
        };
        CpfgRandom { expr: Lcg48::new(expr), choice: Lcg48::new(choice), kept }
    }

    /// `srand(s)`: the expression stream restarts and the kept normal value is dropped.
    pub fn srand(&mut self, s: f64) {
        // cpfg converts to a C `long` (truncation; out-of-range values saturate here).
        self.expr = Lcg48::new(srand_state(s as i64));
        self.kept = None;
    }

    /// `nran(mean, sd)`: the polar method, two normal values per accepted pair.
    pub fn normal(&mut self, mean: f64, sd: f64) -> f64 {
        if let Some(g) = self.kept.take() {
            return g * sd + mean;
        }
        // The acceptance test passes with probability π/4; the bound only keeps a
        // pathological state from looping (it never binds for a real stream).
        for _ in 0..10_000 {
            let v1 = 2.0 * self.expr.draw() - 1.0;
            let v2 = 2.0 * self.expr.draw() - 1.0;
            let r = v1 * v1 + v2 * v2;
            if r < 1.0 && r != 0.0 {
                let fac = (-2.0 * r.ln() / r).sqrt();
                self.kept = Some(v1 * fac);
                return v2 * fac * sd + mean;
            }
        }
        mean
    }

    /// `bran(a, b)`: a Beta(a, b) draw (Cheng1978, algorithm BA, as cpfg runs it).
    pub fn beta(&mut self, a: f64, b: f64) -> f64 {
        let s = a + b;
        let lambda = if a.min(b) <= 1.0 { a.min(b) } else { ((2.0 * a * b - s) / (s - 2.0)).sqrt() };
        let u = a + lambda;
        let mut ym = 0.0;
        for _ in 0..100_000 {
            let u1 = self.nonzero();
            let u2 = self.nonzero();
            let v = (1.0 / lambda) * (u1 / (1.0 - u1)).ln();
            ym = a * v.exp();
            if s * (s / (b + ym)).ln() + u * v - 4f64.ln() >= (u1 * u1 * u2).ln() {
                break;
            }
        }
        ym / (b + ym)
    }

    /// A draw of the expression stream that is not 0 (cpfg draws again on 0).
    fn nonzero(&mut self) -> f64 {
        loop {
            let x = self.expr.draw();
            if x != 0.0 {
                return x;
            }
        }
    }

    /// `biran(n, p)`: how many of n draws are at most p.
    pub fn binomial(&mut self, n: u64, p: f64) -> f64 {
        (0..n).filter(|_| self.expr.draw() <= p).count() as f64
    }
}

/// The generator state of a derivation.
#[derive(Debug, Clone)]
pub enum Draws {
    /// sylva's generator.
    Sylva(Pcg64),
    /// cpfg's generator.
    Cpfg(CpfgRandom),
}

impl Draws {
    /// sylva's generator seeded with `seed`.
    pub fn sylva(seed: u64) -> Self {
        Draws::Sylva(Pcg64::seed_from_u64(seed))
    }

    /// Whether this is cpfg's generator.
    pub fn is_cpfg(&self) -> bool {
        matches!(self, Draws::Cpfg(_))
    }

    /// A uniform draw in [0, 1) for `ran`.
    pub fn uniform(&mut self) -> f64 {
        match self {
            Draws::Sylva(r) => r.random::<f64>(),
            Draws::Cpfg(c) => c.expr.draw(),
        }
    }

    /// A uniform draw in [0, 1) for choosing a stochastic production (cpfg's choice
    /// stream; sylva's single stream).
    pub fn choice(&mut self) -> f64 {
        match self {
            Draws::Sylva(r) => r.random::<f64>(),
            Draws::Cpfg(c) => c.choice.draw(),
        }
    }

    /// `nran(mean, sd)`.
    pub fn normal(&mut self, mean: f64, sd: f64) -> f64 {
        match self {
            Draws::Sylva(r) => mean + sd * sylva_normal(r),
            Draws::Cpfg(c) => c.normal(mean, sd),
        }
    }

    /// `bran(a, b)`; NaN unless a, b > 0.
    pub fn beta(&mut self, a: f64, b: f64) -> f64 {
        if !(a > 0.0 && b > 0.0) {
            return f64::NAN;
        }
        match self {
            Draws::Sylva(r) => {
                let x = sylva_gamma(a, r);
                let y = sylva_gamma(b, r);
                x / (x + y)
            }
            Draws::Cpfg(c) => c.beta(a, b),
        }
    }

    /// `biran(n, p)`.
    pub fn binomial(&mut self, n: u64, p: f64) -> f64 {
        match self {
            Draws::Sylva(r) => (0..n).filter(|_| r.random::<f64>() < p).count() as f64,
            Draws::Cpfg(c) => c.binomial(n, p),
        }
    }

    /// `srand(s)`.
    pub fn srand(&mut self, s: f64) {
        match self {
            Draws::Sylva(r) => *r = Pcg64::seed_from_u64(s as i64 as u64),
            Draws::Cpfg(c) => c.srand(s),
        }
    }
}

/// A standard normal draw (Box–Muller; 1 − u keeps the logarithm's argument in (0, 1]).
fn sylva_normal(rng: &mut Pcg64) -> f64 {
    let u1 = 1.0 - rng.random::<f64>();
    let u2 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A Gamma(k, 1) draw (MarsagliaTsang2000), k > 0.
fn sylva_gamma(k: f64, rng: &mut Pcg64) -> f64 {
    if k < 1.0 {
        let u = 1.0 - rng.random::<f64>();
        return sylva_gamma(k + 1.0, rng) * u.powf(1.0 / k);
    }
    let d = k - 1.0 / 3.0;
    let c = 1.0 / (9.0 * d).sqrt();
    for _ in 0..1000 {
        let x = sylva_normal(rng);
        let v = (1.0 + c * x).powi(3);
        if v <= 0.0 {
            continue;
        }
        let u = 1.0 - rng.random::<f64>();
        if u.ln() < 0.5 * x * x + d - d * v + d * v.ln() {
            return d * v;
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lcg48_is_posix_drand48() {
        // srand48(0) sets X = 0x330E; the first drand48() is then (a·0x330E + 0xB)/2⁴⁸.
        let mut r = Lcg48::new(0x330E);
        let want = ((0x5DEECE66D_u64 * 0x330E + 0xB) & MASK48) as f64 / 2f64.powi(48);
        assert_eq!(r.draw(), want);
        // The unseeded glibc state 0: the first draw is 0xB / 2⁴⁸.
        assert_eq!(Lcg48::new(0).draw(), 11.0 / 2f64.powi(48));
    }

    #[test]
    fn seeds_are_cpfgs() {
        let c = CpfgRandom::new(Some(2454), None);
        assert_eq!(c.choice.state, 155 << 32 | 2454);
        assert_eq!(c.expr.state, 0x330E);
        // seed: 0 leaves the unseeded state; a replacement seed below 2¹⁶ is cpfg's.
        assert_eq!(CpfgRandom::new(Some(0), None).choice.state, 0);
        assert_eq!(CpfgRandom::new(Some(2454), Some(7)).choice, CpfgRandom::new(Some(7), None).choice);
        let mut c = CpfgRandom::new(None, None);
        c.srand(21.0);
        assert_eq!(c.expr.state, 21 << 16 | 0x330E);
    }

    #[test]
    fn first_nran_before_srand_is_the_mean() {
        let mut c = CpfgRandom::new(None, None);
        assert_eq!(c.normal(80.0, 4.0), 80.0);
        let second = c.normal(80.0, 4.0);
        assert_ne!(second, 80.0);
        c.srand(1.0);
        assert_ne!(c.normal(0.0, 1.0), 0.0);
    }
}
