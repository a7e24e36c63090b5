//! The turtle's run over a module string: its state and the branch stack, rotations,
//! tropism (ABOP §2.2), sub-L-system scaling, polygons, organs and the control points
//! of generalized cylinders, all written into a [`Skeleton`] (ABOP ch. 1.5,
//! McLoughlin2021 §4).

use super::commands::{command, sym_is_recording, Cmd};
use super::movements::{after_move, before_move, Frame, Movement};
use super::sweep::{sweep_organ, Sweep, SweepPoint, MAX_RINGS};
use super::{QueryState, TurtleOptions, MAX_NESTING, MAX_TROPISMS};
use crate::lsystem::parse::Symbols;
use crate::lsystem::source::{ErrorKind, LsystemError, Source};
use crate::lsystem::string::ModuleString;
use crate::skeleton::{Organ, OrganKind, Skeleton, NO_PARENT};
use glam::{DVec2, DVec3};

#[derive(Debug, Clone, Copy)]
struct State {
    pos: DVec3,
    h: DVec3,
    l: DVec3,
    u: DVec3,
    width: f64,
    node: u32,
    order: u16,
    material: u32,
    elasticity: [f64; MAX_TROPISMS],
    /// The elasticity of cpfg's old tropism (`_` changes it).
    old_elasticity: f64,
    /// The heading and up vector when the last `F`/`G` ended (cpfg's tropisms keep the
    /// up vector from there).
    prev_h: DVec3,
    prev_u: DVec3,
    /// Last node of the open generalized cylinder (`@Gs` … `@Ge`), if any.
    gc: u32,
    /// Length scale of the open sub-L-systems (`?(n, scale)`), 1 outside them.
    scale: f64,
    /// The selected contour (`@#`): an index into the run's shapes, 0 the circle.
    contour: u32,
    /// The open contour-swept generalized cylinder (an index into the run's sweeps), or
    /// [`NO_PARENT`].
    sweep: u32,
    /// How many control points of that sweep this state has seen.
    sweep_seen: u32,
    /// Set in a branch (`[`) opened inside a sweep: its first control point forks the
    /// sweep from the last point seen, as cpfg's spline stack does.
    sweep_branch: bool,
}

/// Bends the heading toward every tropism (ABOP §2.2: α = e·‖H × T‖ about H × T),
/// never past the target direction; then rebuilds an orthonormal frame.
fn apply_tropisms(st: &mut State, tropisms: &[(DVec3, Option<f64>)]) {
    for (k, &(t, cone)) in tropisms.iter().enumerate() {
        let e = st.elasticity[k];
        if e == 0.0 || t == DVec3::ZERO {
            continue;
        }
        let axis = st.h.cross(t);
        let sin = axis.length();
        if sin < 1e-12 {
            continue;
        }
        let theta = st.h.dot(t).clamp(-1.0, 1.0).acos();
        // Plagiotropism: the target is the cone at angle A around T.
        let (gap, strength) = match cone {
            None => (theta, sin),
            Some(a) => (theta - a, (theta - a).sin()),
        };
        let mut alpha = e * strength;
        // Never turn past the target direction.
        if gap >= 0.0 {
            alpha = alpha.clamp(0.0, gap);
        } else {
            alpha = alpha.clamp(gap, 0.0);
        }
        let q = glam::DQuat::from_axis_angle(axis / sin, alpha);
        st.h = (q * st.h).normalize();
        st.l = q * st.l;
        st.u = st.h.cross(st.l).normalize();
        st.l = st.u.cross(st.h).normalize();
    }
}

/// Rotates the pair (a, b) by angle (cos c, sin s): a' = a c + b s, b' = −a s + b c.
#[inline]
fn rotate(a: &mut DVec3, b: &mut DVec3, c: f64, s: f64) {
    let na = *a * c + *b * s;
    let nb = *b * c - *a * s;
    *a = na;
    *b = nb;
}

pub(super) fn run(
    symbols: &Symbols,
    string: &ModuleString,
    opts: &TurtleOptions,
    source: &Source,
    on_draw: &mut dyn FnMut(DVec3, DVec3),
    on_query: &mut dyn FnMut(usize, QueryState),
) -> Result<Skeleton, Box<LsystemError>> {
    let fail = |what: String| source.error_nowhere(ErrorKind::NonFinite, &what);
    // A branch or polygon opened past [`MAX_NESTING`] levels, or whose saved state
    // cannot be allocated.
    let too_deep = |i: usize, what: &str| {
        source
            .error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "module {i} of the derived string opens {what} more than {MAX_NESTING} levels deep, the \
                     turtle's limit on nesting (each open level keeps a saved state)"
                ),
            )
            .with_help("close the branches the grammar opens (`[` … `]`), or derive fewer steps (-n)")
    };
    for (name, v) in [
        ("angle", opts.angle),
        ("step", opts.step),
        ("width", opts.width),
        ("width factor", opts.width_factor),
    ] {
        if !v.is_finite() {
            return Err(fail(format!("turtle {name} is not a finite number")));
        }
    }
    if opts.width < 0.0 {
        return Err(fail(format!("turtle width {} is negative", opts.width)));
    }
    let cmds: Vec<Cmd> = (0..symbols.len()).map(|i| command(symbols.name(i as u16))).collect();
    let (dsin, dcos) = opts.angle.to_radians().sin_cos();
    let mut sk = Skeleton::new();
    let draws = string.syms.iter().filter(|&&s| cmds[s as usize] == Cmd::Draw).count();
    // Each `F` makes a node (and a branch from a new place a root too): at most 2 per draw.
    if draws > opts.max_nodes {
        return Err(source
            .error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "the string draws {draws} internodes: more than the skeleton node budget of {} nodes \
                     (`generator.max_nodes`)",
                    opts.max_nodes
                ),
            )
            .with_help(crate::skeleton::NODE_BUDGET_HELP));
    }
    // Fallibly (issue 39): the query pass has no node budget, so its skeleton may be
    // as large as the string.
    if sk.position.try_reserve_exact(draws + 1).is_err()
        || sk.radius.try_reserve_exact(draws + 1).is_err()
        || sk.parent.try_reserve_exact(draws + 1).is_err()
        || sk.up.try_reserve_exact(draws + 1).is_err()
        || sk.order.try_reserve_exact(draws + 1).is_err()
        || sk.material.try_reserve_exact(draws + 1).is_err()
    {
        return Err(source
            .error_nowhere(
                ErrorKind::Budget,
                &format!(
                    "the string draws {draws} internodes: the turtle's skeleton of as many nodes needs more \
                     memory than is available"
                ),
            )
            .with_help(
                "derive fewer steps (-n), or lower the module budget with --set generator.max_modules=N",
            ));
    }
    let left = DVec3::from(opts.left)
        .try_normalize()
        .filter(|l| l.is_finite() && l.dot(DVec3::Y).abs() < 1e-9)
        .unwrap_or(DVec3::Z);
    let mut st = State {
        pos: DVec3::ZERO,
        h: DVec3::Y,
        l: left,
        u: DVec3::Y.cross(left),
        width: opts.width,
        node: NO_PARENT,
        order: 0,
        material: 0,
        elasticity: [0.0; MAX_TROPISMS],
        old_elasticity: 0.0,
        prev_h: DVec3::Y,
        prev_u: DVec3::Y.cross(left),
        gc: NO_PARENT,
        scale: 1.0,
        contour: 0,
        sweep: NO_PARENT,
        sweep_seen: 0,
        sweep_branch: false,
    };
    // Shape 0 is the circle (cpfg's default contour: cos, sin from angle 0), then the
    // view file's contours in order.
    let sides = opts.contour_sides.clamp(3, crate::lsystem::files::contour::MAX_SIDES);
    let mut shapes: Vec<(Vec<DVec2>, bool, i32)> = vec![(
        (0..sides)
            .map(|k| {
                let (s, c) = (std::f64::consts::TAU * k as f64 / sides as f64).sin_cos();
                DVec2::new(c, s)
            })
            .collect(),
        true,
        0,
    )];
    for c in &opts.contours {
        shapes.push((c.points.iter().map(|p| DVec2::from_array(*p)).collect(), c.closed, c.id));
    }
    let mut sweeps: Vec<Sweep> = Vec::new();
    for (k, t) in opts.tropisms.iter().enumerate() {
        st.elasticity[k] = t.elasticity;
    }
    // cpfg's tropisms replace ABOP's rule when a view file gives them (issue 46).
    let cpfg = opts.cpfg_tropisms.as_ref();
    let cpfg_moves: &[Movement] =
        cpfg.map(|c| &c.movements[..c.movements.len().min(MAX_TROPISMS)]).unwrap_or(&[]);
    let cpfg_old =
        cpfg.and_then(|c| c.old).map(|o| (DVec3::from_array(o.direction).normalize_or_zero(), o.increment));
    if let Some(c) = cpfg {
        for (k, m) in cpfg_moves.iter().enumerate() {
            st.elasticity[k] = m.elasticity;
        }
        st.old_elasticity = c.old.map_or(0.0, |o| o.elasticity);
    }
    let frame_of = |st: &State| Frame { h: st.h, l: st.l, u: st.u, prev_h: st.prev_h, prev_u: st.prev_u };
    let set_frame = |st: &mut State, f: Frame| {
        st.h = f.h;
        st.l = f.l;
        st.u = f.u;
        st.prev_h = f.prev_h;
        st.prev_u = f.prev_u;
    };
    // Root nodes by exact position (see `Cmd::Draw`).
    let mut roots: std::collections::HashMap<[u64; 3], u32> = std::collections::HashMap::new();
    let abop_tropisms: &[super::Tropism] = if cpfg.is_some() { &[] } else { &opts.tropisms };
    let tropisms: Vec<(DVec3, Option<f64>)> = abop_tropisms
        .iter()
        .map(|t| (DVec3::from_array(t.direction).normalize_or_zero(), t.angle.map(f64::to_radians)))
        .collect();
    let mut stack: Vec<State> = Vec::new();
    // Stack depths at which the open sub-L-systems saved their state.
    let mut subs: Vec<usize> = Vec::new();
    // Open polygons (a stack: `{` inside `{`), each a list of vertices.
    let mut polygons: Vec<Vec<DVec3>> = Vec::new();
    let mut i = 0;
    let n = string.len();
    while i < n {
        let (sym, p) = string.module(i);
        let arg = p.first().copied();
        let moves = cpfg.is_some() && matches!(cmds[sym as usize], Cmd::Draw | Cmd::Move);
        if moves {
            // cpfg's `tropism:`/`torque:` lines act before each move.
            let mut f = frame_of(&st);
            before_move(&mut f, cpfg_moves, &st.elasticity[..cpfg_moves.len()]);
            set_frame(&mut st, f);
        }
        match cmds[sym as usize] {
            Cmd::None => {}
            Cmd::Move if !polygons.is_empty() => {
                // Inside a polygon, `f` adds a vertex of its outline (`g` moves without one).
                st.pos += st.h * arg.unwrap_or(opts.step) * st.scale;
                if sym_is_recording(symbols.name(sym)) {
                    polygons.last_mut().expect("non-empty").push(st.pos);
                }
            }
            // A zero-length internode draws nothing, as in cpfg (issue 46 item 11): no
            // node, no segment, and no ABOP tropism (cpfg's tropisms still act, above);
            // inside a polygon an `F(0)` still adds its vertex.
            Cmd::Draw if arg.unwrap_or(opts.step) * st.scale == 0.0 => {
                if !polygons.is_empty() && sym_is_recording(symbols.name(sym)) {
                    polygons.last_mut().expect("non-empty").push(st.pos);
                }
            }
            Cmd::Draw => {
                if !polygons.is_empty()
                    && st.node != NO_PARENT
                    && sk.position[st.node as usize].as_dvec3().distance(st.pos) > 0.0
                {
                    // An internode inside a polygon starts where the outline has moved the turtle.
                    st.node = NO_PARENT;
                }
                if st.node == NO_PARENT {
                    // Branches starting where a root already is share it (an axiom
                    // `[F…][F…]` is one plant with several stems, not several plants
                    // whose bases overlap).
                    let key = st.pos.to_array().map(|c| (c + 0.0).to_bits());
                    st.node = match roots.get(&key) {
                        Some(&r) => r,
                        None => {
                            let r = sk.push(
                                st.pos.as_vec3(),
                                (st.width * 0.5) as f32,
                                NO_PARENT,
                                st.u.as_vec3(),
                                st.order,
                            );
                            *sk.material.last_mut().expect("just pushed") = st.material;
                            roots.insert(key, r);
                            r
                        }
                    };
                }
                let start = st.pos;
                st.pos += st.h * arg.unwrap_or(opts.step) * st.scale;
                on_draw(start, st.pos);
                if !polygons.is_empty() && sym_is_recording(symbols.name(sym)) {
                    // Inside a polygon cpfg's `F` both draws its internode and adds a
                    // vertex of the outline (issue 46: `WeepingBirch`'s leaves); `G`
                    // only draws.
                    polygons.last_mut().expect("non-empty").push(st.pos);
                }
                st.node =
                    sk.push(st.pos.as_vec3(), (st.width * 0.5) as f32, st.node, st.u.as_vec3(), st.order);
                *sk.material.last_mut().expect("just pushed") = st.material;
                if !tropisms.is_empty() {
                    apply_tropisms(&mut st, &tropisms);
                }
            }
            Cmd::Move => {
                st.pos += st.h * arg.unwrap_or(opts.step) * st.scale;
                st.node = NO_PARENT;
            }
            Cmd::Turn(sign) | Cmd::Pitch(sign) | Cmd::Roll(sign) => {
                let (s, c) = match arg {
                    Some(a) => a.to_radians().sin_cos(),
                    None => (dsin, dcos),
                };
                let s = s * sign;
                match cmds[sym as usize] {
                    Cmd::Turn(_) => rotate(&mut st.h, &mut st.l, c, s),
                    // Pitch down (+): H toward −U, i.e. U toward H.
                    Cmd::Pitch(_) => rotate(&mut st.u, &mut st.h, c, s),
                    // Roll right (+): U toward L, as real cpfg rolls (issue 46 item 1:
                    // cpfg's up is −(H × L), so with this frame's U = H × L its `/`
                    // moves L away from U; `+ - & ^` agree either way).
                    _ => rotate(&mut st.u, &mut st.l, c, s),
                }
            }
            Cmd::TurnAround => {
                st.h = -st.h;
                st.l = -st.l;
            }
            Cmd::SubStart if !p.is_empty() => {
                // A sub-L-system is drawn like a branch, its lengths scaled.
                if stack.len() >= MAX_NESTING || stack.try_reserve(1).is_err() || subs.try_reserve(1).is_err()
                {
                    return Err(too_deep(i, "a sub-L-system (`?`)"));
                }
                subs.push(stack.len());
                stack.push(st);
                let s = p.get(1).copied().unwrap_or(1.0);
                if !(s.is_finite() && s > 0.0) {
                    return Err(fail(format!(
                        "module {i} (`?`) calls a sub-L-system with scale {s}; it must be > 0"
                    )));
                }
                st.scale *= s;
            }
            Cmd::SubStart => {}
            Cmd::Dollar if !subs.is_empty() => {
                let depth = subs.pop().expect("non-empty");
                if stack.len() <= depth {
                    return Err(source.error_nowhere(
                        ErrorKind::Syntax,
                        &format!("module {i} of the derived string (`$`) closes a sub-L-system across a `]`"),
                    ));
                }
                stack.truncate(depth + 1);
                st = stack.pop().expect("depth < len");
            }
            Cmd::RollHorizontal | Cmd::Dollar => {
                let l = DVec3::Y.cross(st.h);
                if l.length_squared() > 1e-24 {
                    st.l = l.normalize();
                    st.h = st.h.normalize();
                    st.u = st.h.cross(st.l);
                }
            }
            Cmd::Push => {
                if stack.len() >= MAX_NESTING || stack.try_reserve(1).is_err() {
                    return Err(too_deep(i, "a branch (`[`)"));
                }
                stack.push(st);
                st.order = st.order.saturating_add(1);
                st.sweep_branch = st.sweep != NO_PARENT;
            }
            Cmd::Pop => match stack.pop() {
                Some(s) => st = s,
                None => {
                    return Err(source.error_nowhere(
                        ErrorKind::Syntax,
                        &format!("module {i} of the derived string is a `]` without a matching `[`"),
                    ))
                }
            },
            Cmd::Width => {
                st.width = arg.unwrap_or(match opts.width_increment {
                    Some(d) => (st.width - d).max(0.0),
                    None => st.width * opts.width_factor,
                });
                if st.width < 0.0 {
                    return Err(fail(format!(
                        "module {i} of the derived string (`!({})`) sets a negative width",
                        st.width
                    )));
                }
            }
            Cmd::WidthUp => {
                st.width = arg.unwrap_or(match opts.width_increment {
                    Some(d) => st.width + d,
                    None => st.width / opts.width_factor.max(1e-9),
                });
                if st.width < 0.0 {
                    return Err(fail(format!("module {i} (`#`) sets a negative width {}", st.width)));
                }
            }
            Cmd::Material(step) => {
                st.material = match arg {
                    Some(v) => v.max(0.0) as u32,
                    None => st.material.saturating_add_signed(step),
                };
            }
            Cmd::Elasticity if cpfg.is_some() => {
                // cpfg's `_` changes the old tropism's elasticity only.
                st.old_elasticity = arg.unwrap_or(st.old_elasticity + cpfg_old.map_or(0.0, |o| o.1));
            }
            Cmd::Elasticity => {
                for k in 0..tropisms.len() {
                    st.elasticity[k] = arg.unwrap_or(st.elasticity[k] + opts.elasticity_increment);
                }
            }
            Cmd::SetElasticity => {
                // @Ts(i, e): tropism i (1-based); @Ts(e) sets the first.
                let (k, e) = match p {
                    [i, e, ..] => (*i as i64 - 1, *e),
                    [e] => (0, *e),
                    [] => (0, 0.0),
                };
                if k >= 0 && (k as usize) < tropisms.len().max(cpfg_moves.len()) {
                    st.elasticity[k as usize] = e;
                }
            }
            Cmd::MoveTo => {
                if let [x, y, z, ..] = p {
                    st.pos = DVec3::new(*x, *y, *z);
                    st.node = NO_PARENT;
                }
            }
            Cmd::SetHeading => {
                if let [hx, hy, hz, rest @ ..] = p {
                    let h = DVec3::new(*hx, *hy, *hz).normalize_or_zero();
                    if h != DVec3::ZERO {
                        let up = match rest {
                            [ux, uy, uz, ..] => DVec3::new(*ux, *uy, *uz),
                            _ => st.u,
                        };
                        let mut u = (up - h * up.dot(h)).normalize_or_zero();
                        if u == DVec3::ZERO {
                            u = h.any_orthonormal_vector();
                        }
                        st.h = h;
                        st.u = u;
                        st.l = u.cross(h);
                    }
                }
            }
            Cmd::Query => on_query(i, [st.pos, st.h, st.u, st.l]),
            Cmd::Contour => {
                let n = arg.unwrap_or(0.0);
                if !n.is_finite() {
                    return Err(fail(format!(
                        "module {i} (`@#({n})`) selects a contour that is not a number"
                    )));
                }
                let id = n.round() as i64;
                st.contour = if id == 0 {
                    0
                } else {
                    match opts.contours.iter().position(|c| i64::from(c.id) == id) {
                        Some(k) if opts.contours[k].error.is_some() => {
                            return Err(source.error_nowhere(
                                ErrorKind::Syntax,
                                &format!(
                                    "module {i} of the derived string (`@#({id})`) selects contour {id}, which cannot \
                                     be used: {}",
                                    opts.contours[k].error.as_deref().unwrap_or("")
                                ),
                            ));
                        }
                        Some(k) => k as u32 + 1,
                        None => {
                            let declared: Vec<String> =
                                opts.contours.iter().map(|c| c.id.to_string()).collect();
                            return Err(source.error_nowhere(
                                ErrorKind::OutOfRange,
                                &format!(
                                    "module {i} of the derived string (`@#({id})`) selects contour {id}, but the view \
                                     file declares no `contour: {id} file.con` line (declared: {})",
                                    if declared.is_empty() { "none".to_string() } else { declared.join(", ") }
                                ),
                            ));
                        }
                    }
                };
            }
            Cmd::CylinderStart | Cmd::CylinderPoint | Cmd::CylinderEnd
                if st.contour != 0 || st.sweep != NO_PARENT =>
            {
                if st.gc != NO_PARENT {
                    let e = source.error_nowhere(
                        ErrorKind::Unsupported,
                        &format!(
                            "unsupported: module {i} of the derived string (`{}`) switches a generalized cylinder \
                             started with the circle to a contour (`@#` before its `@Gs`)",
                            symbols.name(sym)
                        ),
                    );
                    return Err(e);
                }
                let rings = match arg {
                    Some(r) if r.is_finite() => (r.round().max(1.0) as u32).min(MAX_RINGS),
                    _ => 1,
                };
                let point = SweepPoint {
                    pos: st.pos,
                    h: st.h,
                    u: st.u,
                    radius: st.width * 0.5,
                    shape: st.contour,
                    rings,
                };
                let kind = cmds[sym as usize];
                let open = st.sweep != NO_PARENT && kind != Cmd::CylinderStart;
                if open
                    && !st.sweep_branch
                    && sweeps[st.sweep as usize].points.len() == st.sweep_seen as usize
                {
                    sweeps[st.sweep as usize].points.push(point);
                    st.sweep_seen += 1;
                } else {
                    // A new sweep (`@Gs`, or `@Gc` with none open, as cpfg starts one), or a
                    // branch continuing its parent's: it starts from the last point it saw.
                    let mut points = Vec::new();
                    if open {
                        points.push(sweeps[st.sweep as usize].points[st.sweep_seen as usize - 1]);
                    }
                    points.push(point);
                    st.sweep_seen = points.len() as u32;
                    st.sweep_branch = false;
                    st.sweep = sweeps.len() as u32;
                    sweeps.push(Sweep { points, node: st.node, material: st.material, module: i });
                }
                if kind == Cmd::CylinderEnd {
                    st.sweep = NO_PARENT;
                    st.sweep_seen = 0;
                }
            }
            Cmd::CylinderStart => {
                st.gc =
                    sk.push(st.pos.as_vec3(), (st.width * 0.5) as f32, NO_PARENT, st.u.as_vec3(), st.order);
                *sk.material.last_mut().expect("just pushed") = st.material;
            }
            Cmd::CylinderPoint | Cmd::CylinderEnd => {
                if st.gc != NO_PARENT {
                    let prev = sk.position[st.gc as usize].as_dvec3();
                    on_draw(prev, st.pos);
                    st.gc =
                        sk.push(st.pos.as_vec3(), (st.width * 0.5) as f32, st.gc, st.u.as_vec3(), st.order);
                    *sk.material.last_mut().expect("just pushed") = st.material;
                    if matches!(cmds[sym as usize], Cmd::CylinderEnd) {
                        st.gc = NO_PARENT;
                    }
                }
            }
            Cmd::PolygonStart => {
                if polygons.len() >= MAX_NESTING || polygons.try_reserve(1).is_err() {
                    return Err(too_deep(i, "a polygon (`{`)"));
                }
                polygons.push(vec![st.pos]);
            }
            Cmd::Vertex => {
                if let Some(poly) = polygons.last_mut() {
                    if poly.last().is_none_or(|v| v.distance(st.pos) > 1e-12) {
                        poly.push(st.pos);
                    }
                }
            }
            Cmd::PolygonEnd => {
                if let Some(mut poly) = polygons.pop() {
                    if poly.len() > 3 && poly[0].distance(*poly.last().expect("non-empty")) < 1e-9 {
                        poly.pop();
                    }
                    if poly.len() >= 3 {
                        sk.organs.push(Organ {
                            kind: OrganKind::Polygon(poly.iter().map(|v| v.as_vec3()).collect()),
                            node: st.node,
                            position: poly[0].as_vec3(),
                            heading: st.h.as_vec3(),
                            up: st.u.as_vec3(),
                            size: 1.0,
                            material: st.material,
                        });
                    }
                }
            }
            Cmd::Surface | Cmd::Sphere | Cmd::Disc => {
                let name = symbols.name(sym);
                let (kind, size) = match cmds[sym as usize] {
                    Cmd::Surface => (OrganKind::Surface(name[1..].to_string()), arg.unwrap_or(1.0)),
                    Cmd::Sphere => (OrganKind::Sphere, arg.unwrap_or(st.width) * 0.5),
                    _ => (OrganKind::Disc, arg.unwrap_or(st.width) * 0.5),
                };
                let mut size = size * st.scale;
                if cmds[sym as usize] != Cmd::Surface {
                    // cpfg draws `@O(-d)` / `@o(-d)` as the sphere or disc of |d|
                    // (tiny negative sizes come from function tables, issue 46).
                    size = size.abs();
                }
                if !size.is_finite() || size < 0.0 {
                    return Err(fail(format!(
                        "module {i} (`{name}`) has a negative or non-finite size {size}"
                    )));
                }
                sk.organs.push(Organ {
                    kind,
                    node: st.node,
                    position: st.pos.as_vec3(),
                    heading: st.h.as_vec3(),
                    up: st.u.as_vec3(),
                    size: size as f32,
                    material: st.material,
                });
            }
        }
        if moves {
            // cpfg's old tropism acts after each move; an `F`/`G` ends a segment.
            let mut f = frame_of(&st);
            if let Some((t, _)) = cpfg_old {
                after_move(&mut f, t, st.old_elasticity);
            }
            if cmds[sym as usize] == Cmd::Draw {
                f.prev_h = f.h;
                f.prev_u = f.u;
            }
            set_frame(&mut st, f);
        }
        i += 1;
    }
    let budget = opts.max_nodes.saturating_mul(16);
    let mut used = 0usize;
    for sw in &sweeps {
        if let Some(organ) = sweep_organ(sw, &shapes, opts.twist_of_cylinders, source, &mut used, budget)? {
            sk.organs.push(organ);
        }
    }
    sk.validate().map_err(|e| fail(format!("the turtle produced an invalid skeleton: {e}")))?;
    Ok(sk)
}
