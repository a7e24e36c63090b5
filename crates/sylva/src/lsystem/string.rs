//! The module string: the plain data that derivation (`derive`) writes and the turtle
//! (`turtle`) reads, stored flat (seed 002 §2; seed 001 §4.3). Imports no other stage,
//! so the two can depend on it without depending on each other.

/// A string of parametric modules, stored flat: symbol ids plus parameter offsets.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ModuleString {
    /// Symbol id of each module.
    pub syms: Vec<u16>,
    /// Parameter offsets: module i's parameters are `params[pofs[i]..pofs[i+1]]`.
    pub pofs: Vec<u32>,
    /// All parameters.
    pub params: Vec<f64>,
}

impl ModuleString {
    /// An empty string.
    pub fn new() -> Self {
        ModuleString { syms: Vec::new(), pofs: vec![0], params: Vec::new() }
    }

    /// An empty string with room for `modules` modules and `params` parameters.
    pub fn with_capacity(modules: usize, params: usize) -> Self {
        let mut pofs = Vec::with_capacity(modules + 1);
        pofs.push(0);
        ModuleString { syms: Vec::with_capacity(modules), pofs, params: Vec::with_capacity(params) }
    }

    /// Number of modules.
    pub fn len(&self) -> usize {
        self.syms.len()
    }

    /// True when there are no modules.
    pub fn is_empty(&self) -> bool {
        self.syms.is_empty()
    }

    /// Symbol and parameters of module `i`.
    #[inline]
    pub fn module(&self, i: usize) -> (u16, &[f64]) {
        (self.syms[i], &self.params[self.pofs[i] as usize..self.pofs[i + 1] as usize])
    }

    /// Appends a module.
    #[inline]
    pub fn push(&mut self, sym: u16, params: &[f64]) {
        self.syms.push(sym);
        self.params.extend_from_slice(params);
        self.pofs.push(self.params.len() as u32);
    }

    /// Number of modules with symbol `sym`.
    pub fn count(&self, sym: u16) -> usize {
        self.syms.iter().filter(|&&s| s == sym).count()
    }
}
