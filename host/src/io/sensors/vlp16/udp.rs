//! A live sensor on UDP ([`Vlp16Udp`]) and the decoding benchmark.

use super::*;
use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A live VLP-16 on UDP: bind to the data port and receive one scan per rotation.
///
/// A sensor broadcasts its data packets to port 2368; bind `0.0.0.0:2368` (or the address of the
/// interface the sensor is on) to hear one. Datagrams that are not data packets are counted as
/// rejected and skipped.
#[derive(Debug)]
pub struct Vlp16Udp {
    socket: UdpSocket,
    dec: Decoder,
    datagrams: u64,
    buf: Vec<u8>,
}

impl Vlp16Udp {
    /// Binds a socket (port 0 picks a free one: see [`local_addr`](Self::local_addr)).
    /// An unusable configuration is an `InvalidInput` error.
    pub fn bind(addr: SocketAddr, cfg: Vlp16Config) -> io::Result<Self> {
        let dec = Decoder::new(cfg).map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
        let socket = UdpSocket::bind(addr)?;
        Ok(Self { socket, dec, datagrams: 0, buf: vec![0; 2048] })
    }

    /// The address bound.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    /// Datagrams by fate so far (`offset` of a [`Rejected`] is the datagram's index).
    pub fn counts(&self) -> PacketCounts {
        self.dec.counts
    }

    /// The first rejected datagrams.
    pub fn rejects(&self) -> &[Rejected] {
        &self.dec.rejects
    }

    /// Waits up to `timeout` for a rotation to end and returns it; `None` on timeout (the
    /// rotation in progress is kept for the next call).
    pub fn recv_scan(&mut self, timeout: Duration) -> Result<Option<PlanarScan>, Vlp16Error> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            self.socket.set_read_timeout(Some(left)).map_err(|source| Vlp16Error::Io { path: None, source })?;
            match self.socket.recv_from(&mut self.buf) {
                Ok((n, _from)) => {
                    let index = self.datagrams;
                    self.datagrams += 1;
                    let Self { dec, buf, .. } = self;
                    if let Some(scan) = dec.payload(index, &buf[..n]) {
                        return Ok(Some(scan));
                    }
                }
                Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted) => {}
                Err(source) => return Err(Vlp16Error::Io { path: None, source }),
            }
        }
    }
}

/// Throughput of decode + binning measured by [`bench_decode`].
#[derive(Debug, Clone, Copy)]
pub struct DecodeBench {
    /// Packets per repetition.
    pub packets: usize,
    /// Median wall time of one repetition, milliseconds.
    pub median_ms: f64,
    /// Packets per second at the median.
    pub packets_per_s: f64,
}

/// The recorded VLP-16 payloads the benchmark and tests use (`tests/data/velodyne/`).
pub fn default_recording() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/velodyne/einride_vlp16_recording.bin")
}

/// Times checking, decoding and binning the payloads of `path` (raw format) into scans with the
/// default configuration, `reps` times; `None` if the file cannot be read.
pub fn bench_decode(path: &Path, reps: usize) -> Option<DecodeBench> {
    let bytes = std::fs::read(path).ok()?;
    let packets = bytes.len() / PACKET_LEN;
    let mut times = Vec::with_capacity(reps.max(1));
    let mut scans = 0;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        let r = CaptureFormat::Raw.decode_bytes(path, &bytes, &Vlp16Config::default()).ok()?;
        scans = std::hint::black_box(r.scans.len());
        times.push(t.elapsed().as_secs_f64());
    }
    std::hint::black_box(scans);
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    Some(DecodeBench { packets, median_ms: median * 1e3, packets_per_s: packets as f64 / median })
}
