//! Opening a file the user named: the format readers of `io` go through here, so a FIFO
//! (which would block forever), a device such as `/dev/zero` (which never ends) or a folder
//! is refused with one line before a byte is read, and no file is read past a size cap. The
//! session file and its journal are refused by the same rule (`session::refuse_special_file`)
//! and read whole: a session holds a whole project, its values bounded once parsed.
//!
//! Start with [`read_input`] / [`read_input_string`]; [`check_regular_file`] for readers that
//! hand the path to another library (an image decoder, a child program).

use super::error::{FormatError, Result};
use std::fs::{File, Metadata};
use std::io::Read;
use std::path::Path;

/// The cap for inputs without a tighter natural bound: larger than any model, mesh, track or
/// alignment lipmap reads (the biggest real model file is ~300 MB), small enough that a
/// mistaken path cannot exhaust memory.
pub const MAX_INPUT_BYTES: u64 = 4 << 30;

/// Refuses anything but a regular file (after following symlinks): names the file and what it
/// is instead. Reads no data, so it never blocks on a FIFO.
///
/// # Errors
/// The file missing or unreadable, or a folder, FIFO, socket or device.
pub fn check_regular_file(path: &Path) -> Result<Metadata> {
    let meta = std::fs::metadata(path).map_err(|e| FormatError::io(path, e))?;
    if meta.is_file() {
        return Ok(meta);
    }
    Err(FormatError::whole(path, format!("not a regular file ({})", kind_of(&meta))))
}

/// What a non-regular file is, in words.
fn kind_of(meta: &Metadata) -> &'static str {
    if meta.is_dir() {
        return "a folder";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_socket() {
            return "a socket";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
    }
    "not a file"
}

/// Opens a regular file for reading, refusing anything that is not one and any file larger
/// than `max_bytes`.
///
/// # Errors
/// As [`check_regular_file`], or the file over `max_bytes`.
pub fn open_input(path: &Path, max_bytes: u64) -> Result<File> {
    open_input_sized(path, max_bytes).map(|(file, _)| file)
}

/// [`open_input`] with the length the check read, for a reader that streams the file and
/// checks the sizes it states against that length.
///
/// # Errors
/// As [`open_input`].
pub fn open_input_sized(path: &Path, max_bytes: u64) -> Result<(File, u64)> {
    let meta = check_regular_file(path)?;
    if meta.len() > max_bytes {
        return Err(FormatError::whole(
            path,
            format!("{} bytes, more than the {} this kind of file can need", meta.len(), max_bytes),
        ));
    }
    let file = File::open(path).map_err(|e| FormatError::io(path, e))?;
    Ok((file, meta.len()))
}

/// The bytes of a regular file of at most `max_bytes` (a file growing while read is cut off
/// there and refused).
///
/// # Errors
/// As [`open_input`], or a read error.
pub fn read_input_capped(path: &Path, max_bytes: u64) -> Result<Vec<u8>> {
    let (file, len) = open_input_sized(path, max_bytes)?;
    // One allocation of the file's length (+1 for the end-of-file probe) instead of a
    // dozen doublings for a model of megabytes.
    let mut bytes = Vec::with_capacity(usize::try_from(len).unwrap_or(0).saturating_add(1));
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| FormatError::io(path, e))?;
    if bytes.len() as u64 > max_bytes {
        return Err(FormatError::whole(path, format!("grew past {max_bytes} bytes while read")));
    }
    Ok(bytes)
}

/// The bytes of a regular file, capped at [`MAX_INPUT_BYTES`].
///
/// # Errors
/// As [`read_input_capped`].
///
/// ```
/// let err = lipmap::io::input::read_input(std::path::Path::new("/dev/zero")).unwrap_err();
/// assert_eq!(err.to_string(), "/dev/zero: not a regular file (a device)");
/// ```
pub fn read_input(path: &Path) -> Result<Vec<u8>> {
    read_input_capped(path, MAX_INPUT_BYTES)
}

/// The UTF-8 text of a regular file, capped at [`MAX_INPUT_BYTES`].
///
/// # Errors
/// As [`read_input`], or text that is not UTF-8 (naming the byte offset).
pub fn read_input_string(path: &Path) -> Result<String> {
    let bytes = read_input(path)?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to() as u64;
        FormatError::new(path, super::error::Location::Offset(at), "not UTF-8 text")
    })
}

/// `text` without a leading UTF-8 byte-order mark, which Windows editors write and which
/// would otherwise be read as part of the first token.
pub fn without_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_a_regular_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        std::fs::write(&p, "héllo").unwrap();
        assert_eq!(read_input_string(&p).unwrap(), "héllo");
        assert_eq!(read_input(&p).unwrap().len(), 6);
    }

    #[test]
    fn refuses_a_folder_a_device_and_a_missing_file_in_one_line() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_input(dir.path()).unwrap_err().to_string();
        assert!(e.ends_with("not a regular file (a folder)"), "{e}");
        if Path::new("/dev/zero").exists() {
            let e = read_input(Path::new("/dev/zero")).unwrap_err().to_string();
            assert_eq!(e, "/dev/zero: not a regular file (a device)");
        }
        let missing = dir.path().join("missing");
        let e = read_input(&missing).unwrap_err().to_string();
        assert_eq!(e.matches(&*missing.to_string_lossy()).count(), 1, "{e}");
        assert!(!e.contains('\n'));
    }

    #[test]
    fn refuses_a_fifo_without_blocking() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("model.bin");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("skipped: mkfifo not available");
            return;
        }
        let e = read_input(&fifo).unwrap_err().to_string();
        assert!(e.ends_with("not a regular file (a FIFO)"), "{e}");
    }

    #[test]
    fn refuses_a_file_over_the_cap_and_text_that_is_not_utf8() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big");
        std::fs::write(&p, [0u8; 100]).unwrap();
        assert!(read_input_capped(&p, 100).is_ok());
        let e = read_input_capped(&p, 99).unwrap_err().to_string();
        assert!(e.contains("100 bytes"), "{e}");
        std::fs::write(&p, [b'a', 0xff]).unwrap();
        let e = read_input_string(&p).unwrap_err().to_string();
        assert!(e.contains("byte 1: not UTF-8"), "{e}");
    }
}
