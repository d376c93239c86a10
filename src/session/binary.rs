//! The container of a session's per-clip data files (`.track`, `.fits`): little-endian
//! records behind a small JSON header, with a 64-bit FNV-1a of everything before it as the
//! last 8 bytes (it also names the file, so equal contents share one file).
//!
//! ```text
//! magic     8 bytes   b"lipmap\0T" (tracked landmarks) or b"lipmap\0F" (cached fits)
//! version   u16       the file format version (1)
//! reserved  u16       0
//! head_len  u32       bytes of the JSON header that follows (≤ MAX_HEADER_BYTES)
//! head      JSON      what the records are (clip name, counts, fit settings)
//! records   …         kind-specific (track_file.rs, fits_file.rs)
//! checksum  u64       FNV-1a of every byte above
//! ```
//!
//! The files are untrusted like every input: [`Reader`] reads through a buffer (the bytes are
//! never held beside what they decode to), names the record and field of every fault and the
//! byte it is at, refuses counts the file is too short to hold before anything is sized by
//! them, and refuses trailing bytes and a wrong checksum.

use super::SessionError;
use super::cache::Fnv64;
use std::io::{BufReader, Read, Write};
use std::path::{Path, PathBuf};

/// Largest JSON header: a clip's name and up to eight fit settings fit in a few KB.
pub const MAX_HEADER_BYTES: u32 = 1 << 20;

/// Which kind of data a file holds, from its magic bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Track,
    Fits,
}

impl Kind {
    fn magic(self) -> &'static [u8; 8] {
        match self {
            Kind::Track => b"lipmap\0T",
            Kind::Fits => b"lipmap\0F",
        }
    }

    /// The file name extension.
    pub fn extension(self) -> &'static str {
        match self {
            Kind::Track => "track",
            Kind::Fits => "fits",
        }
    }

    fn what(self) -> &'static str {
        match self {
            Kind::Track => "tracked landmarks",
            Kind::Fits => "cached fits",
        }
    }
}

/// Writes a file's bytes to `out` while hashing them; [`Writer::finish`] appends the hash.
pub struct Writer<W: Write> {
    out: W,
    hash: Fnv64,
}

impl<W: Write> Writer<W> {
    /// Starts a file of `kind`, version `version`, with `header` as its JSON header.
    ///
    /// # Errors
    /// The writer's I/O error.
    pub fn start(out: W, kind: Kind, version: u16, header: &[u8]) -> std::io::Result<Self> {
        let mut w = Self { out, hash: Fnv64::default() };
        w.bytes(kind.magic())?;
        w.u16(version)?;
        w.u16(0)?;
        w.u32(u32::try_from(header.len()).unwrap_or(u32::MAX))?;
        w.bytes(header)?;
        Ok(w)
    }

    pub fn bytes(&mut self, b: &[u8]) -> std::io::Result<()> {
        self.hash.bytes(b);
        self.out.write_all(b)
    }

    pub fn u8(&mut self, v: u8) -> std::io::Result<()> {
        self.bytes(&[v])
    }

    pub fn u16(&mut self, v: u16) -> std::io::Result<()> {
        self.bytes(&v.to_le_bytes())
    }

    pub fn u32(&mut self, v: u32) -> std::io::Result<()> {
        self.bytes(&v.to_le_bytes())
    }

    pub fn f32(&mut self, v: f32) -> std::io::Result<()> {
        self.bytes(&v.to_le_bytes())
    }

    pub fn f64(&mut self, v: f64) -> std::io::Result<()> {
        self.bytes(&v.to_le_bytes())
    }

    /// A short string: its length in one byte, then its UTF-8 bytes (at most 255).
    pub fn short_str(&mut self, s: &str) -> std::io::Result<()> {
        let b = s.as_bytes();
        let n = b.len().min(255);
        self.u8(n as u8)?;
        self.bytes(&b[..n])
    }

    /// A 68-entry (or shorter) bit set, 9 bytes, bit `i` of byte `i / 8`.
    pub fn mask(&mut self, set: impl Fn(usize) -> bool) -> std::io::Result<()> {
        let mut m = [0u8; MASK_BYTES];
        for (i, byte) in m.iter_mut().enumerate() {
            for bit in 0..8 {
                if set(i * 8 + bit) {
                    *byte |= 1 << bit;
                }
            }
        }
        self.bytes(&m)
    }

    /// Appends the checksum and returns it (the hash of every byte written so far).
    ///
    /// # Errors
    /// The writer's I/O error.
    pub fn finish(mut self) -> std::io::Result<u64> {
        let h = self.hash.finish();
        self.out.write_all(&h.to_le_bytes())?;
        self.out.flush()?;
        Ok(h)
    }
}

/// Bytes of a point bit set (68 points).
pub const MASK_BYTES: usize = 9;

/// Whether bit `i` of a mask is set.
pub fn mask_has(mask: &[u8; MASK_BYTES], i: usize) -> bool {
    mask.get(i / 8).is_some_and(|b| b & (1 << (i % 8)) != 0)
}

/// A sink that only hashes: a file's name is its checksum, known before it is written.
#[derive(Default)]
pub struct HashOnly;

impl Write for HashOnly {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Reads one data file: the container checks, and typed reads that name what they read.
pub struct Reader {
    input: BufReader<std::fs::File>,
    path: PathBuf,
    hash: Fnv64,
    /// Bytes read so far.
    pos: u64,
    /// The file's length (bytes left = len − pos − 8 for the checksum).
    len: u64,
    /// The record being read, for messages: e.g. `frame record 12 (frame 40)`.
    record: String,
}

/// A fault in a data file: `path: [record: ]field: message (byte N)`.
fn fault(path: &Path, record: &str, field: &str, pos: u64, message: &str) -> SessionError {
    let at = if record.is_empty() { String::new() } else { format!("{record}: ") };
    SessionError::Invalid {
        path: path.to_path_buf(),
        message: format!("{at}{field}: {message} (byte {pos})"),
    }
}

impl Reader {
    /// Opens `path`, expecting a file of `kind`: checks the magic and the version (≤
    /// `newest`) and returns the reader positioned after the JSON header, the version and
    /// the header's bytes.
    ///
    /// # Errors
    /// Not a regular file, unreadable, too short, another kind of file, a newer version, a
    /// header longer than [`MAX_HEADER_BYTES`] or than the file.
    pub fn open(
        path: &Path,
        kind: Kind,
        newest: u16,
    ) -> Result<(Self, u16, Vec<u8>), SessionError> {
        let io = |source| SessionError::Io { path: path.to_path_buf(), source };
        let meta = crate::io::input::check_regular_file(path)
            .map_err(|e| SessionError::Invalid { path: path.to_path_buf(), message: e.message })?;
        let file = std::fs::File::open(path).map_err(io)?;
        let mut r = Self {
            input: BufReader::with_capacity(1 << 16, file),
            path: path.to_path_buf(),
            hash: Fnv64::default(),
            pos: 0,
            len: meta.len(),
            record: String::new(),
        };
        if r.len < 20 + 8 {
            return Err(
                r.fault("header", &format!("{} bytes is too short for a lipmap data file", r.len))
            );
        }
        let mut magic = [0u8; 8];
        r.fill(&mut magic, "magic")?;
        if &magic != kind.magic() {
            let other = [Kind::Track, Kind::Fits].into_iter().find(|k| &magic == k.magic());
            let message = match other {
                Some(k) => format!("holds {}, not {}", k.what(), kind.what()),
                None => format!("not a lipmap file of {}", kind.what()),
            };
            return Err(r.fault("magic", &message));
        }
        let version = r.u16("version")?;
        if version == 0 || version > newest {
            return Err(r.fault(
                "version",
                &format!(
                    "format version {version}; this build reads 1 to {newest} (update lipmap)"
                ),
            ));
        }
        if r.u16("reserved")? != 0 {
            return Err(r.fault("reserved", "must be 0"));
        }
        let n = r.u32("head_len")?;
        if n > MAX_HEADER_BYTES || u64::from(n) > r.remaining() {
            return Err(r.fault("head_len", &format!("{n} bytes is more than the file holds")));
        }
        let mut head = vec![0u8; n as usize];
        r.fill(&mut head, "head")?;
        Ok((r, version, head))
    }

    /// Parses the JSON header as `T`, naming the file and serde's message.
    ///
    /// # Errors
    /// The header is not the JSON `T` expects.
    pub fn header<T: serde::de::DeserializeOwned>(&self, head: &[u8]) -> Result<T, SessionError> {
        serde_json::from_slice(head).map_err(|e| SessionError::Invalid {
            path: self.path.clone(),
            message: format!("header: {e}"),
        })
    }

    /// The file being read.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Bytes left before the checksum.
    pub fn remaining(&self) -> u64 {
        self.len.saturating_sub(self.pos).saturating_sub(8)
    }

    /// Names the record being read in later messages.
    pub fn set_record(&mut self, record: String) {
        self.record = record;
    }

    /// A fault at the current position in the current record.
    pub fn fault(&self, field: &str, message: &str) -> SessionError {
        fault(&self.path, &self.record, field, self.pos, message)
    }

    /// Refuses `count` items of at least `min_bytes` each when the rest of the file cannot
    /// hold them, before anything is sized by the count.
    ///
    /// # Errors
    /// The count is larger than the file.
    pub fn check_count(&self, field: &str, count: u64, min_bytes: u64) -> Result<(), SessionError> {
        if count.saturating_mul(min_bytes) > self.remaining() {
            return Err(self.fault(
                field,
                &format!("{count} is more than the {} bytes left can hold", self.remaining()),
            ));
        }
        Ok(())
    }

    pub fn fill(&mut self, buf: &mut [u8], field: &str) -> Result<(), SessionError> {
        if buf.len() as u64 > self.remaining() {
            return Err(self.fault(field, "the file ends here"));
        }
        self.input.read_exact(buf).map_err(|e| self.fault(field, &e.to_string()))?;
        self.hash.bytes(buf);
        self.pos += buf.len() as u64;
        Ok(())
    }

    pub fn u8(&mut self, field: &str) -> Result<u8, SessionError> {
        let mut b = [0u8; 1];
        self.fill(&mut b, field)?;
        Ok(b[0])
    }

    pub fn u16(&mut self, field: &str) -> Result<u16, SessionError> {
        let mut b = [0u8; 2];
        self.fill(&mut b, field)?;
        Ok(u16::from_le_bytes(b))
    }

    pub fn u32(&mut self, field: &str) -> Result<u32, SessionError> {
        let mut b = [0u8; 4];
        self.fill(&mut b, field)?;
        Ok(u32::from_le_bytes(b))
    }

    pub fn f32(&mut self, field: &str) -> Result<f32, SessionError> {
        let mut b = [0u8; 4];
        self.fill(&mut b, field)?;
        Ok(f32::from_le_bytes(b))
    }

    /// A finite `f64`.
    pub fn f64(&mut self, field: &str) -> Result<f64, SessionError> {
        let mut b = [0u8; 8];
        self.fill(&mut b, field)?;
        let v = f64::from_le_bytes(b);
        if !v.is_finite() {
            return Err(self.fault(field, "is not a finite number"));
        }
        Ok(v)
    }

    /// `out.len()` finite `f64`s in one read.
    pub fn f64s(&mut self, out: &mut [f64], field: &str) -> Result<(), SessionError> {
        let mut b = vec![0u8; out.len() * 8];
        self.fill(&mut b, field)?;
        for (k, (v, c)) in out.iter_mut().zip(b.chunks_exact(8)).enumerate() {
            *v = f64::from_le_bytes(c.try_into().expect("8 bytes"));
            if !v.is_finite() {
                return Err(self.fault(&format!("{field}[{k}]"), "is not a finite number"));
            }
        }
        Ok(())
    }

    pub fn mask(&mut self, field: &str) -> Result<[u8; MASK_BYTES], SessionError> {
        let mut m = [0u8; MASK_BYTES];
        self.fill(&mut m, field)?;
        Ok(m)
    }

    /// A string written by [`Writer::short_str`].
    pub fn short_str(&mut self, field: &str) -> Result<String, SessionError> {
        let n = self.u8(field)?;
        let mut b = vec![0u8; usize::from(n)];
        self.fill(&mut b, field)?;
        String::from_utf8(b).map_err(|_| self.fault(field, "is not UTF-8 text"))
    }

    /// Checks that only the checksum is left and that it matches the bytes read; returns it.
    ///
    /// # Errors
    /// Bytes left over, or a checksum that does not match (the file was changed or damaged).
    pub fn finish(mut self) -> Result<u64, SessionError> {
        self.record.clear();
        if self.remaining() != 0 {
            return Err(
                self.fault("records", &format!("{} bytes past the last record", self.remaining()))
            );
        }
        let expected = self.hash.finish();
        let mut b = [0u8; 8];
        self.input.read_exact(&mut b).map_err(|e| self.fault("checksum", &e.to_string()))?;
        self.pos += 8;
        let found = u64::from_le_bytes(b);
        if found != expected {
            return Err(self.fault(
                "checksum",
                &format!(
                    "{found:016x} does not match the contents ({expected:016x}): the file was changed or damaged"
                ),
            ));
        }
        Ok(found)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(path: &Path, kind: Kind, body: impl Fn(&mut Writer<&mut Vec<u8>>)) -> Vec<u8> {
        let mut bytes = Vec::new();
        let mut w = Writer::start(&mut bytes, kind, 1, br#"{"n":2}"#).unwrap();
        body(&mut w);
        w.finish().unwrap();
        std::fs::write(path, &bytes).unwrap();
        bytes
    }

    #[test]
    fn round_trip_and_each_container_fault_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.track");
        let bytes = write(&p, Kind::Track, |w| {
            w.u32(7).unwrap();
            w.f64(1.5).unwrap();
            w.short_str("héllo").unwrap();
        });
        let (mut r, version, head) = Reader::open(&p, Kind::Track, 1).unwrap();
        assert_eq!((version, head.as_slice()), (1, br#"{"n":2}"#.as_slice()));
        assert_eq!(r.u32("n").unwrap(), 7);
        assert_eq!(r.f64("x").unwrap(), 1.5);
        assert_eq!(r.short_str("s").unwrap(), "héllo");
        r.finish().unwrap();

        let refused = |bytes: &[u8], kind: Kind, want: &str| {
            std::fs::write(&p, bytes).unwrap();
            let e = match Reader::open(&p, kind, 1) {
                Err(e) => e.to_string(),
                Ok((mut r, _, _)) => {
                    let e = r.u32("n").and_then(|_| r.f64("x")).and_then(|_| r.short_str("s"));
                    match e {
                        Err(e) => e.to_string(),
                        Ok(_) => r.finish().unwrap_err().to_string(),
                    }
                }
            };
            assert!(e.contains(want) && e.contains("a.track") && !e.contains('\n'), "{e}");
        };
        refused(&bytes, Kind::Fits, "holds tracked landmarks, not cached fits");
        let mut newer = bytes.clone();
        newer[8] = 9;
        refused(&newer, Kind::Track, "format version 9");
        refused(&bytes[..bytes.len() - 3], Kind::Track, "the file ends here");
        // Records start after the 16-byte container head and the 7-byte JSON header.
        let body = 16 + 7;
        let mut flipped = bytes.clone();
        flipped[body + 7] ^= 1;
        refused(&flipped, Kind::Track, "checksum");
        let mut nan = bytes.clone();
        nan[body + 4..body + 12].copy_from_slice(&f64::NAN.to_le_bytes());
        refused(&nan, Kind::Track, "x: is not a finite number");
        let mut longer = bytes[..bytes.len() - 8].to_vec();
        longer.push(0);
        longer.extend_from_slice(&bytes[bytes.len() - 8..]);
        refused(&longer, Kind::Track, "1 bytes past the last record");
        let mut head = bytes.clone();
        head[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        refused(&head, Kind::Track, "head_len");
        refused(b"short", Kind::Track, "too short");
    }

    #[test]
    fn counts_larger_than_the_file_are_refused_before_sizing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.fits");
        write(&p, Kind::Fits, |w| w.u32(1).unwrap());
        let (r, _, _) = Reader::open(&p, Kind::Fits, 1).unwrap();
        assert!(r.check_count("frames", 1, 4).is_ok());
        let e = r.check_count("frames", 1 << 40, 4).unwrap_err().to_string();
        assert!(e.contains("frames: 1099511627776 is more than the 4 bytes left"), "{e}");
    }
}
