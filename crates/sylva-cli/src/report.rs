//! Printing errors: miette's report, with a plain fallback should its renderer panic,
//! and the start of the engine's threads, whose failure is an error naming
//! `RAYON_NUM_THREADS`.

use miette::Result;

/// Prints an error with miette's handler. The report is rendered into a string first;
/// should the renderer panic on some input (miette's graphical handler did on columns
/// past 65,535; located errors now carry clipped excerpts), the panic is caught,
/// silently, and the plain message, its causes and its help are printed instead:
/// printing an error never panics.
pub fn report(e: &miette::Report) {
    eprintln!("{}", render_report(e));
}

/// The text [`report`] prints: miette's rendering, or the plain fallback.
pub fn render_report(e: &miette::Report) -> String {
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let rendered = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| format!("{e:?}")));
    std::panic::set_hook(hook);
    rendered.unwrap_or_else(|_| {
        let mut text = format!("Error: {e}");
        for cause in e.chain().skip(1) {
            text.push_str(&format!("\n  caused by: {cause}"));
        }
        if let Some(help) = e.help() {
            text.push_str(&format!("\n  help: {help}"));
        }
        text
    })
}

/// Installs miette's handler: long messages stay on one line so they can be searched and
/// copied whole.
pub fn install() {
    let _ =
        miette::set_hook(Box::new(|_| Box::new(miette::MietteHandlerOpts::new().wrap_lines(false).build())));
}

/// Starts the engine's worker threads before any work, so a `RAYON_NUM_THREADS` above
/// [`sylva::refine::MAX_THREADS`], or one the system cannot start, is an error naming
/// it rather than a panic at the first parallel step.
pub fn start_threads() -> Result<()> {
    sylva::refine::start_global_threads().map_err(|e| match std::env::var("RAYON_NUM_THREADS") {
        Ok(v) => miette::miette!("RAYON_NUM_THREADS={}: {e}", sylva::diagnostic::quote(&v)),
        Err(_) => miette::miette!("{e}"),
    })
}

#[cfg(test)]
mod tests {
    use super::render_report;
    use miette::{Diagnostic, MietteError, SourceCode, SourceSpan, SpanContents};

    /// Source code whose every read panics, as miette's renderer did on long lines.
    #[derive(Debug)]
    struct Exploding;

    impl SourceCode for Exploding {
        fn read_span<'a>(
            &'a self,
            _: &SourceSpan,
            _: usize,
            _: usize,
        ) -> Result<Box<dyn SpanContents<'a> + 'a>, MietteError> {
            panic!("Formatting argument out of range")
        }
    }

    #[derive(Debug, Diagnostic)]
    #[diagnostic(help("fix it"))]
    struct Bad {
        #[source_code]
        src: Exploding,
        #[label("here")]
        span: SourceSpan,
    }

    impl std::fmt::Display for Bad {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("t.l:1:70000: bad")
        }
    }

    impl std::error::Error for Bad {}

    #[test]
    fn a_renderer_panic_falls_back_to_the_plain_message() {
        let e = miette::Report::new(Bad { src: Exploding, span: SourceSpan::new(0.into(), 1) });
        let text = render_report(&e);
        assert!(text.starts_with("Error: t.l:1:70000: bad"), "{text}");
        assert!(text.contains("help: fix it"), "{text}");
    }
}
