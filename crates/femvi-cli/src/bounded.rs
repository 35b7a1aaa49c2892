//! Bounded reads of the files a user names (problem files and standard input, BVP guesses,
//! `--states`, checkpoints and summaries): each is read through a guard that refuses it past
//! a size limit, and a text file also at its first NUL byte or past a line-length limit, so
//! that `/dev/zero`, a FIFO that never ends or a huge file is an input error within a moment
//! and bounded memory instead of an endless read or an abort (issue 34).

use std::io::Read;
use std::path::Path;

/// The largest problem file (or standard input) read: 256 MiB (an FPU chain of 10⁶ masses
/// with its 2·10⁶ initial numbers is about 40 MB).
pub const MAX_PROBLEM_BYTES: u64 = 256 << 20;
/// The largest data file read (BVP guesses, `--states`, checkpoints, summaries): 512 MiB.
pub const MAX_DATA_BYTES: u64 = 512 << 20;
/// The longest line of a CSV data file: 16 MiB.
pub const MAX_LINE_BYTES: u64 = 16 << 20;

/// What a file must look like.
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// Bytes in all.
    pub total: u64,
    /// Bytes per line, for text files whose lines are bounded (None: any length).
    pub line: Option<u64>,
    /// A text file: a NUL byte ends the read with an error.
    pub text: bool,
}

impl Limits {
    /// A problem file: text of at most [`MAX_PROBLEM_BYTES`], lines of any length.
    pub const PROBLEM: Limits = Limits {
        total: MAX_PROBLEM_BYTES,
        line: None,
        text: true,
    };
    /// A CSV data file: text of at most [`MAX_DATA_BYTES`], lines of at most [`MAX_LINE_BYTES`].
    pub const CSV: Limits = Limits {
        total: MAX_DATA_BYTES,
        line: Some(MAX_LINE_BYTES),
        text: true,
    };
    /// A JSON file the program wrote (checkpoint, summary): text of at most [`MAX_DATA_BYTES`].
    pub const JSON: Limits = Limits {
        total: MAX_DATA_BYTES,
        line: None,
        text: true,
    };
    /// A binary data file (NPY): at most [`MAX_DATA_BYTES`].
    pub const BINARY: Limits = Limits {
        total: MAX_DATA_BYTES,
        line: None,
        text: false,
    };
}

/// A reader that fails (with [`std::io::ErrorKind::InvalidData`]) as soon as its input breaks
/// the [`Limits`].
///
/// # Example
///
/// ```
/// use femvi_cli::bounded::{Guard, Limits};
/// use std::io::Read;
/// let mut out = String::new();
/// let err = Guard::new(std::io::repeat(0).take(10), Limits::PROBLEM).read_to_string(&mut out).unwrap_err();
/// assert!(err.to_string().contains("NUL"));
/// ```
pub struct Guard<R> {
    inner: R,
    limits: Limits,
    read: u64,
    line: u64,
}

impl<R: Read> Guard<R> {
    /// Guards `inner` with `limits`.
    pub fn new(inner: R, limits: Limits) -> Self {
        Self {
            inner,
            limits,
            read: 0,
            line: 0,
        }
    }
}

fn invalid(msg: String) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidData, msg)
}

/// A size in MiB for messages.
fn mib(bytes: u64) -> u64 {
    bytes >> 20
}

impl<R: Read> Read for Guard<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        // One byte beyond the limit is read, so that a file of exactly the limit passes.
        let room = usize::try_from(self.limits.total.saturating_sub(self.read).saturating_add(1)).unwrap_or(usize::MAX);
        let want = buf.len().min(room);
        let got = self.inner.read(&mut buf[..want])?;
        self.read += got as u64;
        if self.read > self.limits.total {
            return Err(invalid(format!(
                "larger than the limit of {} MiB for such a file",
                mib(self.limits.total)
            )));
        }
        if self.limits.text || self.limits.line.is_some() {
            for &b in &buf[..got] {
                if b == 0 && self.limits.text {
                    return Err(invalid("contains a NUL byte: it is not a text file".into()));
                }
                self.line = if b == b'\n' { 0 } else { self.line + 1 };
                if let Some(max) = self.limits.line {
                    if self.line > max {
                        return Err(invalid(format!("has a line longer than the limit of {} MiB", mib(max))));
                    }
                }
            }
        }
        Ok(got)
    }
}

/// Opens `path` behind a [`Guard`].
///
/// # Errors
/// The file cannot be opened.
pub fn open(path: &Path, limits: Limits) -> std::io::Result<Guard<std::fs::File>> {
    Ok(Guard::new(std::fs::File::open(path)?, limits))
}

/// The whole of `path` (or of `reader`, for standard input), within `limits`.
///
/// # Errors
/// The file cannot be read or breaks the limits.
pub fn read(path: &Path, limits: Limits) -> std::io::Result<Vec<u8>> {
    read_from(std::fs::File::open(path)?, limits)
}

/// The whole of `reader` within `limits`.
///
/// # Errors
/// The reader fails or breaks the limits.
pub fn read_from<R: Read>(reader: R, limits: Limits) -> std::io::Result<Vec<u8>> {
    let mut buf = Vec::new();
    Guard::new(reader, limits).read_to_end(&mut buf)?;
    Ok(buf)
}

/// The whole of `path` as UTF-8 text within `limits`.
///
/// # Errors
/// The file cannot be read, breaks the limits or is not UTF-8.
pub fn read_to_string(path: &Path, limits: Limits) -> std::io::Result<String> {
    String::from_utf8(read(path, limits)?)
        .map_err(|e| invalid(format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to())))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits(total: u64, line: Option<u64>) -> Limits {
        Limits {
            total,
            line,
            text: true,
        }
    }

    #[test]
    fn a_file_of_exactly_the_limit_passes_and_one_byte_more_fails() {
        let ten = b"0123456789".to_vec();
        assert_eq!(read_from(&ten[..], limits(10, None)).unwrap(), ten);
        assert!(read_from(&ten[..], limits(9, None)).is_err());
    }

    #[test]
    fn long_lines_and_nul_bytes_are_refused() {
        assert!(read_from(&b"ab\ncd\n"[..], limits(100, Some(2))).is_ok());
        let e = read_from(&b"ab\ncde\n"[..], limits(100, Some(2))).unwrap_err();
        assert!(e.to_string().contains("line longer"), "{e}");
        let e = read_from(&b"ab\0"[..], limits(100, None)).unwrap_err();
        assert!(e.to_string().contains("NUL"), "{e}");
        // Binary files may hold NUL bytes.
        assert!(read_from(&[0u8; 8][..], Limits::BINARY).is_ok());
    }

    #[test]
    fn an_endless_source_ends_at_the_limit() {
        let e = read_from(std::io::repeat(b'1'), limits(1 << 20, None)).unwrap_err();
        assert!(e.to_string().contains("limit of 1 MiB"), "{e}");
    }
}
