//! Module strings as text, cpfg-style (`b[a]a`, `F(1)+(60)F(1)`): one module for
//! messages, a whole string, or a string written out in pieces (Mech2004).

use crate::lsystem::parse::LSystem;
use crate::lsystem::string::ModuleString;

impl LSystem {
    /// One module as text: `A(1,0.5)`.
    pub fn format_module(&self, sym: u16, params: &[f64]) -> String {
        let mut s = String::new();
        self.write_module(&mut s, sym, params);
        s
    }

    fn write_module(&self, s: &mut String, sym: u16, params: &[f64]) {
        use std::fmt::Write;
        s.push_str(self.symbols.name(sym));
        if !params.is_empty() {
            s.push('(');
            for (k, v) in params.iter().enumerate() {
                if k > 0 {
                    s.push(',');
                }
                // Parameters are 32-bit floats (as in cpfg): printed as the shortest
                // text that reads back as the same `f32` (`0.7`, not 0.699999988…).
                if crate::lsystem::string::cpfg_param(*v) == *v {
                    let _ = write!(s, "{}", *v as f32);
                } else {
                    let _ = write!(s, "{v}");
                }
            }
            s.push(')');
        }
    }

    /// Writes the whole string as text, as [`LSystem::format`] makes it, in pieces of
    /// about 64 KiB: a string of hundreds of millions of modules is printed without
    /// its text ever being held whole in memory (issue 39).
    pub fn write_to(&self, m: &ModuleString, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        let mut s = String::with_capacity(1 << 16);
        for i in 0..m.len() {
            let (sym, params) = m.module(i);
            self.write_module(&mut s, sym, params);
            if s.len() >= (1 << 16) - 256 {
                w.write_all(s.as_bytes())?;
                s.clear();
            }
        }
        w.write_all(s.as_bytes())
    }

    /// The whole string as text, cpfg-style (`b[a]a`, `F(1)+(60)F(1)`).
    pub fn format(&self, m: &ModuleString) -> String {
        let mut s = String::with_capacity(m.len() * 2);
        for i in 0..m.len() {
            let (sym, params) = m.module(i);
            self.write_module(&mut s, sym, params);
        }
        s
    }
}
