//! Chunk decompression for MCAP and ROS 1 bags, with a bound on what a damaged chunk can make the
//! reader allocate.

use std::borrow::Cow;

/// The most a chunk may claim to hold uncompressed, whatever the file's size: 1 GiB.
pub const MAX_CHUNK_UNCOMPRESSED: u64 = 1 << 30;
/// The most a chunk may claim to hold uncompressed per byte of the file it is in: 1024 (zstd
/// reaches a few hundred on runs of zeros; rosbag2's chunks of scans reach 3 to 10).
pub const MAX_CHUNK_RATIO: u64 = 1024;

/// How a chunk's records are compressed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Codec {
    /// Stored as they are.
    None,
    /// zstd (MCAP; feature `zstd`).
    Zstd,
    /// LZ4 frames (MCAP, and ROS 1's `roslz4`; feature `lz4`).
    Lz4,
    /// bzip2 (ROS 1).
    Bz2,
}

impl Codec {
    fn name(self) -> &'static str {
        match self {
            Codec::None => "uncompressed",
            Codec::Zstd => "zstd",
            Codec::Lz4 => "lz4",
            Codec::Bz2 => "bz2",
        }
    }
}

/// The `claimed` bytes that `data` (at byte `data_at` of a file of `file_len` bytes) decompresses
/// to. The claim must be within [`MAX_CHUNK_UNCOMPRESSED`] and [`MAX_CHUNK_RATIO`] × the file's
/// size, the decoder may not write more than it and must write all of it. Nothing is allocated
/// beyond the claimed size, so damaged compressed bytes cannot make the reader allocate what they
/// like (the `mcap` crate's own chunk reader sized its buffer from the damaged stream).
pub fn decompress_bounded(codec: Codec, claimed: u64, data: &[u8], data_at: usize, file_len: usize) -> Result<Cow<'_, [u8]>, String> {
    let limit = MAX_CHUNK_UNCOMPRESSED.min((file_len as u64).saturating_mul(MAX_CHUNK_RATIO));
    #[allow(unused_variables)] // every codec's feature on: nothing is missing
    let missing = |feature: &str| {
        format!(
            "chunk compressed with {}, which this `lives` was built without (rebuild with `--features {feature}`, or `ros-bags`)",
            codec.name()
        )
    };
    let out = match codec {
        Codec::None if claimed != data.len() as u64 => {
            return Err(format!("its uncompressed size field says {claimed} bytes, its records take {} (byte {data_at})", data.len()));
        }
        Codec::None => return Ok(Cow::Borrowed(data)),
        _ if claimed > limit => {
            return Err(format!(
                "it claims {claimed} bytes uncompressed from {} compressed, more than this reader allows for a file of {file_len} bytes ({limit}: {MAX_CHUNK_RATIO} × the file's size, at most {MAX_CHUNK_UNCOMPRESSED})",
                data.len()
            ));
        }
        #[cfg(feature = "zstd")]
        Codec::Zstd => zstd::bulk::decompress(data, claimed as usize).map_err(|e| {
            format!("its zstd data (byte {data_at}, {} bytes) does not decompress to the {claimed} bytes it claims: {e}", data.len())
        })?,
        #[cfg(not(feature = "zstd"))]
        Codec::Zstd => return Err(missing("zstd")),
        #[cfg(feature = "lz4")]
        Codec::Lz4 => {
            let decoder = lz4::Decoder::new(data).map_err(|e| format!("its lz4 data (byte {data_at}) does not start a frame: {e}"))?;
            read_bounded(decoder, claimed, "lz4", data_at, data.len())?
        }
        #[cfg(not(feature = "lz4"))]
        Codec::Lz4 => return Err(missing("lz4")),
        Codec::Bz2 => read_bounded(bzip2::read::BzDecoder::new(data), claimed, "bz2", data_at, data.len())?,
    };
    if out.len() as u64 != claimed {
        return Err(format!("its {} data decompresses to {} bytes, not the {claimed} it claims", codec.name(), out.len()));
    }
    Ok(Cow::Owned(out))
}

/// Reads at most `claimed + 1` bytes from a decoder (one more than claimed shows a claim too small).
fn read_bounded(decoder: impl std::io::Read, claimed: u64, name: &str, data_at: usize, len: usize) -> Result<Vec<u8>, String> {
    use std::io::Read;
    let mut out = Vec::new();
    decoder
        .take(claimed + 1)
        .read_to_end(&mut out)
        .map_err(|e| format!("its {name} data (byte {data_at}, {len} bytes) does not decompress: {e}"))?;
    Ok(out)
}
