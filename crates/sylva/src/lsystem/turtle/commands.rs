//! What each module means to the turtle: the command of every symbol name (`F`, `+`,
//! `[`, `@Gs`, `~leaf`, …), looked up once per symbol before a run (ABOP ch. 1.5,
//! Mech2004).

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Cmd {
    None,
    Draw,
    Move,
    Turn(f64),
    Pitch(f64),
    Roll(f64),
    TurnAround,
    RollHorizontal,
    /// `$`: closes the innermost open sub-L-system, else rolls to horizontal.
    Dollar,
    /// `?(n, scale)`: opens a sub-L-system (saves the state, scales lengths).
    SubStart,
    Push,
    Pop,
    Width,
    WidthUp,
    Material(i32),
    Elasticity,
    SetElasticity,
    MoveTo,
    SetHeading,
    PolygonStart,
    PolygonEnd,
    Vertex,
    Surface,
    Sphere,
    Disc,
    CylinderStart,
    CylinderPoint,
    CylinderEnd,
    /// `@#(n)`: selects contour n for generalized cylinders.
    Contour,
    Query,
}

/// True for the moves that record a polygon vertex (`F`, `f`; not `G`, `g`).
pub(super) fn sym_is_recording(name: &str) -> bool {
    name == "F" || name == "f"
}

pub(super) fn command(name: &str) -> Cmd {
    match name {
        "F" | "G" => Cmd::Draw,
        "f" | "g" => Cmd::Move,
        "+" => Cmd::Turn(1.0),
        "-" => Cmd::Turn(-1.0),
        "&" => Cmd::Pitch(1.0),
        "^" => Cmd::Pitch(-1.0),
        "/" => Cmd::Roll(1.0),
        "\\" => Cmd::Roll(-1.0),
        "|" => Cmd::TurnAround,
        "$" => Cmd::Dollar,
        "?" => Cmd::SubStart,
        "[" => Cmd::Push,
        "]" => Cmd::Pop,
        "!" => Cmd::Width,
        "#" => Cmd::WidthUp,
        ";" => Cmd::Material(1),
        "," => Cmd::Material(-1),
        "_" => Cmd::Elasticity,
        "@Ts" => Cmd::SetElasticity,
        "@M" => Cmd::MoveTo,
        "@R" => Cmd::SetHeading,
        "@v" => Cmd::RollHorizontal,
        "{" => Cmd::PolygonStart,
        "}" => Cmd::PolygonEnd,
        "." => Cmd::Vertex,
        "@O" => Cmd::Sphere,
        "@o" | "@c" => Cmd::Disc,
        "?P" | "?H" | "?U" | "?L" | "?E" => Cmd::Query,
        "@Gs" => Cmd::CylinderStart,
        "@Gc" => Cmd::CylinderPoint,
        "@Ge" => Cmd::CylinderEnd,
        "@#" => Cmd::Contour,
        n if n.starts_with('~') => Cmd::Surface,
        _ => Cmd::None,
    }
}
