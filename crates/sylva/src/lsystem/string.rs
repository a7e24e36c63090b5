//! The module string: the plain data that derivation (`derive`) writes and the turtle
//! (`turtle`) reads, stored flat (McLoughlin2021 §2; MacMurchy2004 §4.3). Imports no other stage,
//! so the two can depend on it without depending on each other.

/// Bytes a module takes in a [`ModuleString`] without its parameters: its symbol (2)
/// and its parameter offset (4). Each parameter adds [`BYTES_PER_PARAMETER`].
pub const BYTES_PER_MODULE: usize = 6;

/// Bytes each parameter of a module takes in a [`ModuleString`].
pub const BYTES_PER_PARAMETER: usize = 8;

/// A parameter as cpfg stores it in its string: a 32-bit float (issue 46 item 2).
/// Expressions are evaluated in double precision, but every value written into a
/// module's parameters (successors, the axiom, query answers) is rounded to `f32`, so
/// accumulated clocks such as `A(t) --> A(t + dt)` cross thresholds in the step that
/// cpfg's do. Kept as `f64` in the string.
#[inline]
pub fn cpfg_param(v: f64) -> f64 {
    v as f32 as f64
}

/// A module string could not grow: the allocator refused `bytes` bytes (issue 39). The
/// derivation turns it into a budget error naming `generator.max_modules`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutOfMemory {
    /// The size of the allocation that failed, in bytes.
    pub bytes: usize,
    /// How many modules the string was to hold.
    pub modules: usize,
}

/// Makes room for `additional` more elements in `v` without aborting: the capacity
/// at least doubles (amortised growth, as `Vec::push`), and a refused allocation is an
/// [`OutOfMemory`] with the bytes asked for (`modules`: the string's size then).
#[inline]
pub(crate) fn try_room<T>(v: &mut Vec<T>, additional: usize, modules: usize) -> Result<(), OutOfMemory> {
    if v.capacity() - v.len() >= additional {
        return Ok(());
    }
    grow(v, additional, modules)
}

#[cold]
fn grow<T>(v: &mut Vec<T>, additional: usize, modules: usize) -> Result<(), OutOfMemory> {
    let want = v.len().saturating_add(additional).max(v.capacity().saturating_mul(2)).max(8);
    let fail = OutOfMemory { bytes: want.saturating_mul(std::mem::size_of::<T>()), modules };
    v.try_reserve_exact(want - v.len()).map_err(|_| fail)
}

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

    /// [`ModuleString::with_capacity`] that fails instead of aborting when the
    /// allocator refuses the memory.
    pub fn try_with_capacity(modules: usize, params: usize) -> Result<Self, OutOfMemory> {
        let mut m = ModuleString::new();
        m.try_reserve_exact(modules, params)?;
        Ok(m)
    }

    /// Makes room for `modules` more modules and `params` more parameters, exactly,
    /// without aborting: an [`OutOfMemory`] when the allocator refuses.
    pub fn try_reserve_exact(&mut self, modules: usize, params: usize) -> Result<(), OutOfMemory> {
        let want = self.len().saturating_add(modules);
        let fail = |bytes: usize| OutOfMemory { bytes, modules: want };
        self.syms.try_reserve_exact(modules).map_err(|_| fail(modules.saturating_mul(2)))?;
        self.pofs.try_reserve_exact(modules).map_err(|_| fail(modules.saturating_mul(4)))?;
        self.params.try_reserve_exact(params).map_err(|_| fail(params.saturating_mul(BYTES_PER_PARAMETER)))
    }

    /// Appends a module like [`ModuleString::push`], but a string that cannot grow is
    /// an [`OutOfMemory`] error instead of an abort.
    #[inline]
    pub fn try_push(&mut self, sym: u16, params: &[f64]) -> Result<(), OutOfMemory> {
        let n = self.syms.len();
        try_room(&mut self.syms, 1, n)?;
        try_room(&mut self.pofs, 1, n)?;
        try_room(&mut self.params, params.len(), n)?;
        self.push(sym, params);
        Ok(())
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
