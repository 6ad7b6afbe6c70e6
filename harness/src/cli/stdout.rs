//! The verbs' output on standard output, where a reader that closed the pipe (`| head`) is an
//! error to end on, not a panic.

use anyhow::Result;

/// Writes to stdout; unlike `print!`, a reader that closed the pipe is an error the caller
/// sees (and `main` ends quietly on), not a panic.
pub fn out(text: std::fmt::Arguments) -> Result<()> {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    stdout.write_fmt(text)?;
    stdout.flush()?;
    Ok(())
}
