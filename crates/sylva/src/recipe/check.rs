//! The checks serde cannot express ([`Recipe::check`]) and the settings resolved
//! against the mesher (`refine.scheme = "auto"`, `refine.boundary = "auto"`).

use super::*;

impl Recipe {
    /// The scheme `[refine]` subdivides the bark with: `None` for `scheme = "none"`;
    /// `auto` is the mesher's ([`Mesher::scheme`]).
    pub fn refine_scheme(&self) -> Option<Scheme> {
        match self.refine.scheme {
            RefineScheme::None => None,
            RefineScheme::Loop => Some(Scheme::Loop),
            RefineScheme::CatmullClark => Some(Scheme::CatmullClark),
            RefineScheme::Auto => Some(self.mesh.mesher().scheme()),
        }
    }

    /// The boundary rule `[refine] boundary` names (`auto`: [`BoundaryInterpolation::Fixed`]
    /// for the hull mesher, Pieterse2012's default, else the B-spline rim).
    ///
    /// [`BoundaryInterpolation::Fixed`]: crate::refine::BoundaryInterpolation::Fixed
    pub fn refine_boundary(&self) -> crate::refine::BoundaryInterpolation {
        use crate::refine::BoundaryInterpolation as B;
        match self.refine.boundary {
            RefineBoundary::Auto if self.mesh.method == MeshMethod::Hull => B::Fixed,
            RefineBoundary::Auto | RefineBoundary::Bspline => B::EdgeAndCorner,
            RefineBoundary::Fixed => B::Fixed,
            RefineBoundary::EdgeOnly => B::EdgeOnly,
        }
    }

    /// Checks value ranges that serde cannot express.
    pub fn check(&self) -> Result<()> {
        let bad = |k: &str, why: String| Err(Error::Recipe(format!("`{k}` {why}")));
        if self.input.max_bytes == 0 {
            return bad(crate::input::MAX_BYTES_KEY, "must be at least 1".into());
        }
        match &self.generator {
            Generator::Lsystem(g) => {
                check_turtle(g.angle, g.step, g.width, Some(g.width_factor))?;
                if g.max_modules == 0 {
                    return bad("generator.max_modules", "must be at least 1".into());
                }
                if let Err(why) = crate::lsystem::derive::check_module_budget(g.max_modules) {
                    return bad("generator.max_modules", why);
                }
                if g.max_nodes == 0 {
                    return bad("generator.max_nodes", "must be at least 1".into());
                }
                if let Some(p) = g.allow_paths.iter().find(|p| p.trim().is_empty()) {
                    return bad("generator.allow_paths", format!("names an empty folder `{p}`"));
                }
                for (k, v) in &g.define {
                    if matches!(v, toml::Value::Table(_) | toml::Value::Array(_)) {
                        return bad(&format!("generator.define.{k}"), "must be a number or a string".into());
                    }
                }
            }
            // Both generators validate their own parameters (naming the key) when they run.
            Generator::SpaceColonization(g) => g.validate()?,
            Generator::WeberPenn(g) => g.validate()?,
            Generator::LeastCost(g) => g.validate()?,
            Generator::Import(g) => {
                check_turtle(g.angle, g.step, g.width, None)?;
                if g.max_nodes == 0 {
                    return bad("generator.max_nodes", "must be at least 1".into());
                }
            }
        }
        // The shared keys first: each mesher's table is checked with them filled in.
        if !(3..=1024).contains(&self.mesh.sides) {
            return bad("mesh.sides", format!("must be in 3..=1024, got {}", self.mesh.sides));
        }
        self.mesh.mesher().check()?;
        // The other meshers' tables too: a bad value is a mistake even where unused.
        for &method in MeshMethod::ALL {
            self.mesh.mesher_for(method).check()?;
        }
        self.fit.decollide.check()?;
        self.fit.clear.check()?;
        if self.refine.levels > 6 {
            return bad(
                "refine.levels",
                format!("is {}; at most 6 (each level multiplies faces by 4)", self.refine.levels),
            );
        }
        if !(1..=REFINE_MAX_FACES_LIMIT).contains(&self.refine.max_faces) {
            return bad(
                "refine.max_faces",
                format!("must be in 1..={REFINE_MAX_FACES_LIMIT}, got {}", self.refine.max_faces),
            );
        }
        for (k, v) in
            [("mesh.max_memory", self.mesh.max_memory), ("refine.max_memory", self.refine.max_memory)]
        {
            if !(1..=REFINE_MAX_MEMORY_LIMIT).contains(&v) {
                return bad(k, format!("must be in 1..={REFINE_MAX_MEMORY_LIMIT} bytes, got {v}"));
            }
        }
        self.textures.check()?;
        self.leaves.check()?;
        self.wind.check()?;
        self.lod.check()?;
        if !(1..=8192).contains(&self.output.preview_size) {
            return bad(
                "output.preview_size",
                format!("must be in 1..=8192, got {}", self.output.preview_size),
            );
        }
        Ok(())
    }
}

/// The turtle's settings of the L-system and import generators (`generator.angle`,
/// `step`, `width`, and for L-systems `width_factor`): finite, the width ≥ 0.
fn check_turtle(angle: f64, step: f64, width: f64, width_factor: Option<f64>) -> Result<()> {
    let bad = |k: &str, why: String| Err(Error::Recipe(format!("`generator.{k}` {why}")));
    let factor = width_factor.map(|f| ("width_factor", f));
    for (k, v) in [("angle", angle), ("step", step), ("width", width)].into_iter().chain(factor) {
        if !v.is_finite() {
            return bad(k, format!("must be a finite number, got {v}"));
        }
    }
    if width < 0.0 {
        return bad("width", format!("must be ≥ 0, got {width}"));
    }
    Ok(())
}
