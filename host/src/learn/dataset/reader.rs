//! Reading a dataset back: the metadata and the records of one split ([`DatasetReader`]).

use std::fs::{self, File};
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use super::*;

/// Read `meta.json` from a dataset directory and check its format and version.
pub fn read_meta(dir: &Path) -> Result<Meta, DatasetError> {
    let path = dir.join("meta.json");
    let text = fs::read_to_string(&path).map_err(|e| DatasetError::Meta { path: path.clone(), message: format!("cannot read: {e}") })?;
    // Check format and version before the full schema, so an old or new file says so.
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| DatasetError::Meta { path: path.clone(), message: format!("not JSON: {e}") })?;
    if v.get("format").and_then(|f| f.as_str()) != Some(FORMAT) {
        return Err(DatasetError::Meta { path, message: format!("`format` is not {FORMAT:?}") });
    }
    let version = v.get("version").and_then(|f| f.as_u64()).unwrap_or(0);
    if version != VERSION as u64 {
        return Err(DatasetError::UnsupportedVersion { path, found: version.min(u32::MAX as u64) as u32, supported: VERSION });
    }
    let meta: Meta = serde_json::from_value(v).map_err(|e| DatasetError::Meta { path: path.clone(), message: e.to_string() })?;
    if meta.beams == 0 || meta.record_bytes != record_bytes(meta.beams) || meta.header_bytes != HEADER_BYTES {
        return Err(DatasetError::Meta { path, message: "beams / record_bytes / header_bytes inconsistent".into() });
    }
    Ok(meta)
}

/// Reads one split of a dataset: random access ([`DatasetReader::get`]) and sequential
/// iteration (`Iterator<Item = Result<Record, DatasetError>>`). A file cut inside a record (or
/// holding fewer records than `meta.json` lists) opens fine: the complete records are readable,
/// [`DatasetReader::truncation`] describes the damage and the iterator yields it as its last item.
pub struct DatasetReader {
    path: PathBuf,
    meta: Meta,
    split: Split,
    file: BufReader<File>,
    beams: usize,
    record_bytes: usize,
    records: u64,
    truncation: Option<DatasetError>,
    /// Next record the iterator returns.
    next: u64,
    /// Record the file position is at.
    at: u64,
    reported: bool,
    buf: Vec<u8>,
}

impl DatasetReader {
    /// Open split `split` of the dataset in `dir`.
    pub fn open(dir: impl AsRef<Path>, split: Split) -> Result<DatasetReader, DatasetError> {
        let dir = dir.as_ref();
        let meta = read_meta(dir)?;
        let sm = meta
            .splits
            .get(split.as_str())
            .cloned()
            .ok_or_else(|| DatasetError::Meta { path: dir.join("meta.json"), message: format!("no `{split}` split listed") })?;
        let path = dir.join(&sm.file);
        let f = File::open(&path).map_err(|e| io_err(&path, e))?;
        let len = f.metadata().map_err(|e| io_err(&path, e))?.len();
        let mut file = BufReader::with_capacity(1 << 16, f);
        let mut h = [0u8; HEADER_BYTES];
        let got = read_full(&mut file, &mut h).map_err(|e| io_err(&path, e))?;
        if got < MAGIC.len() || h[..8] != MAGIC {
            return Err(DatasetError::BadMagic { path, found: h[..got.min(8)].to_vec() });
        }
        if got < HEADER_BYTES {
            return Err(DatasetError::BadHeader { path, message: format!("header is {got} bytes, expected {HEADER_BYTES}") });
        }
        let u32_at = |o: usize| u32::from_le_bytes([h[o], h[o + 1], h[o + 2], h[o + 3]]);
        let version = u32_at(8);
        if version != VERSION {
            return Err(DatasetError::UnsupportedVersion { path, found: version, supported: VERSION });
        }
        let (beams, rb, code) = (u32_at(12) as usize, u32_at(16) as usize, u32_at(20));
        if beams != meta.beams || rb != record_bytes(beams) || code != split.code() {
            return Err(DatasetError::BadHeader {
                path,
                message: format!(
                    "beams {beams}, record bytes {rb}, split code {code}; meta.json says beams {}, record bytes {}, split code {}",
                    meta.beams,
                    record_bytes(meta.beams),
                    split.code()
                ),
            });
        }
        let body = len - HEADER_BYTES as u64;
        let records = body / rb as u64;
        let trailing = body % rb as u64;
        let truncation = (trailing != 0 || records < sm.records).then(|| DatasetError::Truncated {
            path: path.clone(),
            complete_records: records,
            trailing_bytes: trailing,
            expected_records: sm.records,
        });
        Ok(DatasetReader {
            path,
            meta,
            split,
            file,
            beams,
            record_bytes: rb,
            records,
            truncation,
            next: 0,
            at: 0,
            reported: false,
            buf: vec![0u8; rb],
        })
    }

    /// The dataset's `meta.json`.
    pub fn meta(&self) -> &Meta {
        &self.meta
    }

    pub fn split(&self) -> Split {
        self.split
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Complete records in the file.
    pub fn len(&self) -> u64 {
        self.records
    }

    pub fn is_empty(&self) -> bool {
        self.records == 0
    }

    /// `Some(DatasetError::Truncated { .. })` when the file was cut short.
    pub fn truncation(&self) -> Option<&DatasetError> {
        self.truncation.as_ref()
    }

    /// Record `index` (random access).
    pub fn get(&mut self, index: u64) -> Result<Record, DatasetError> {
        if index >= self.records {
            return Err(DatasetError::OutOfRange { index, len: self.records });
        }
        if self.at != index {
            let off = HEADER_BYTES as u64 + index * self.record_bytes as u64;
            self.file.seek(SeekFrom::Start(off)).map_err(|e| io_err(&self.path, e))?;
            self.at = index;
        }
        let got = read_full(&mut self.file, &mut self.buf).map_err(|e| io_err(&self.path, e))?;
        if got != self.record_bytes {
            // The file shrank under us.
            self.at = u64::MAX;
            return Err(DatasetError::Truncated {
                path: self.path.clone(),
                complete_records: index,
                trailing_bytes: got as u64,
                expected_records: self.records,
            });
        }
        self.at = index + 1;
        Record::decode(&self.buf, self.beams)
            .ok_or_else(|| DatasetError::BadHeader { path: self.path.clone(), message: "record size mismatch".into() })
    }

    /// Restart the iteration at record `index`.
    pub fn rewind_to(&mut self, index: u64) {
        self.next = index;
        self.reported = false;
    }
}

impl Iterator for DatasetReader {
    type Item = Result<Record, DatasetError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.next < self.records {
            let r = self.get(self.next);
            self.next += 1;
            return Some(r);
        }
        if !self.reported {
            self.reported = true;
            if let Some(t) = &self.truncation {
                return Some(Err(t.clone()));
            }
        }
        None
    }
}

/// Read until `buf` is full or the file ends; the number of bytes read.
pub(super) fn read_full(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}
