//! `lives` — LiDAR Informed Visual Search: simulate, run and measure the controller.

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use host::search::{self, PlannerChoice, Robot, SearchSpec};
use host::sim::{Scenario, World};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Parser)]
#[command(name = "lives", version, about = "LiDAR Informed Visual Search: find a target in an unseen building, fast")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

/// What to simulate: the world, scenario, planner and seed (shared by `search` and `bridge`).
#[derive(clap::Args)]
struct RunArgs {
    /// A built-in world (apartment, office, hallway), `random` (with --seed), or a world file (.toml).
    #[arg(long, default_value = "apartment")]
    world: String,
    /// easy or hard (built-in and random worlds; default easy). A world file holds its own
    /// scenario, so it takes none.
    #[arg(long)]
    scenario: Option<Scenario>,
    /// lives, lives-gt, multisensor, nearest, explore-lite or rrt.
    #[arg(long, default_value = "lives")]
    planner: PlannerChoice,
    /// Seed: start jitter, target placement, people, sensor noise (and the random world).
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

#[derive(Subcommand)]
enum Cmd {
    /// Run one simulated search and report the result.
    Search {
        #[command(flatten)]
        run: RunArgs,
        /// Write a picture of the run here.
        #[arg(long)]
        png: Option<PathBuf>,
        /// Print one JSON object instead of the human-readable line.
        #[arg(long)]
        json: bool,
        /// Print every goal the controller chooses, with its utility terms, to stderr.
        #[arg(long)]
        trace: bool,
        /// With each goal `--trace` prints, also print the N best candidate viewpoints of that
        /// planning step (the chosen one marked `*`); implies `--trace`.
        #[arg(long, value_name = "N")]
        trace_candidates: Option<usize>,
        /// The int8 classifier blob for `lives` (docs/model-format.md: a `LabelPoseNet` blob such
        /// as `firmware/model/lives-int8.bin`, or a geometric one); without it `lives` runs the
        /// committed geometric classifier (`firmware/model/lives-geo-int8.bin`).
        #[arg(long)]
        model: Option<PathBuf>,
        /// Override a controller parameter, e.g. `--set w_dist_per_m=2` (repeatable; `lives params` lists them).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// Change the simulated robot, e.g. `--sim speed_mps=0.3` or `--sim camera_range_m=8`
        /// (repeatable; `lives params` lists them). The camera, the LiDAR's range and the body's
        /// size also set the controller's model of them; a `--set` then changes the model alone.
        #[arg(long = "sim", value_name = "NAME=VALUE")]
        sim: Vec<String>,
        /// The simulated robot: `calibrated` (the camera's reach calibrated on the paper's
        /// multisensor baseline, docs/experiments/camera-calibration.md) or `short` (a 4 m
        /// camera). `--sim` then changes it further.
        #[arg(long, default_value = "calibrated")]
        robot: Robot,
        /// Record the run (scans, pose, both grids, frontiers, candidates, goals, detection) to an
        /// MCAP file that Foxglove opens (docs/recording.md).
        #[arg(long, value_name = "FILE.mcap")]
        record: Option<PathBuf>,
    },
    /// Generate the scan-classification dataset (docs/dataset.md) from procedural worlds only.
    Dataset {
        /// Output directory (created; meta.json, train.bin, val.bin in it are replaced).
        #[arg(long)]
        out: PathBuf,
        /// Number of procedural worlds (seeds S, S+1, …).
        #[arg(long, default_value_t = 20)]
        worlds: u32,
        /// Episodes per world.
        #[arg(long, default_value_t = 2)]
        episodes_per_world: u32,
        /// First world seed S; worlds with seed % 5 == 0 go to the validation split.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Shortest episode, seconds.
        #[arg(long, default_value_t = 60.0)]
        min_episode_s: f64,
        /// Longest episode, seconds.
        #[arg(long, default_value_t = 120.0)]
        max_episode_s: f64,
        /// Labeller parameters: `sim` (LTF gate 0.1 m, the default) or `spot` (the paper's 0.7 m).
        #[arg(long, default_value = "sim")]
        labeller: String,
        /// Worlds generated at once (the output does not depend on it).
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// Furniture and clutter density range LO,HI in 0..=1: each world keeps each piece with
        /// probability d, d uniform in the range by a hash of the world seed (default 1,1 = `World::random`).
        #[arg(long, value_delimiter = ',', num_args = 1..=2, default_values_t = [1.0, 1.0])]
        furniture_density: Vec<f64>,
    },
    /// Soak: `lives node` as a process on a pseudo-terminal in real time, the bridge here running
    /// searches back to back over a noisy line with the link pulled every few minutes, then node
    /// and bridge in lockstep for hours of simulated time; memory, descriptors, overruns, link
    /// losses and recoveries recorded; exit 1 on growth, a panic, or a pull not answered by a stop
    /// within one watchdog period (docs/reliability.md).
    Soak {
        /// Wall time of the real-time part, minutes.
        #[arg(long, default_value_t = 30.0)]
        minutes: f64,
        /// Simulated time of the lockstep part, hours.
        #[arg(long, default_value_t = 8.0)]
        sim_hours: f64,
        /// Seconds between link pulls.
        #[arg(long, default_value_t = 180.0)]
        pull_every: f64,
        /// Seconds each pull lasts.
        #[arg(long, default_value_t = 2.5)]
        pull_for: f64,
        /// Probability that a byte on the line is replaced by a random one, each direction.
        #[arg(long, default_value_t = 2e-5)]
        noise: f64,
        /// Seconds between memory samples.
        #[arg(long, default_value_t = 5.0)]
        sample_every: f64,
        /// Memory growth allowed, KiB.
        #[arg(long, default_value_t = 2048)]
        growth_kib: u64,
        /// Seed (noise, searches).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Write the whole report (every sample, every pull) as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// The controller core as a process on a serial device (the deployment on the onboard
    /// computer, or a workstation for testing): sensor frames in, goals out.
    Node {
        /// Serial device (/dev/ttyUSB0, /dev/ttyACM0, a pseudo-terminal); waited for if absent.
        #[arg(long)]
        port: PathBuf,
        /// Baud rate (a real UART only; USB CDC and ptys ignore it).
        #[arg(long, default_value_t = 921_600)]
        baud: u32,
        /// Tick when the host's batch for time t is complete, at t (simulation, tests) instead of
        /// every 200 ms on this process's clock.
        #[arg(long)]
        lockstep: bool,
        /// Stop after this many seconds and print the node's counters as JSON (default: run
        /// until killed).
        #[arg(long)]
        seconds: Option<f64>,
        /// The int8 classifier the node runs on scans that arrive without labels (the robot's;
        /// docs/model-format.md, either format). Default: the committed geometric classifier, as
        /// `lives search --planner lives` and the Cortex-M images run.
        #[arg(long, value_name = "BLOB")]
        model: Option<PathBuf>,
        /// Run no classifier: scans without labels then give `lives` no non-map points (it
        /// behaves as `multisensor`).
        #[arg(long, conflicts_with = "model")]
        no_model: bool,
    },
    /// The host bridge: feeds a source's poses, scans and detections to `lives node` over a
    /// serial device, drives the base with the goals that come back, reports link health.
    Bridge {
        /// Serial device; waited for if absent, reopened if it disappears.
        #[arg(long)]
        port: PathBuf,
        /// Baud rate (a real UART only).
        #[arg(long, default_value_t = 921_600)]
        baud: u32,
        /// Where the data comes from: `sim` (the simulator) or `robot` (a real base through the
        /// base adapter, docs/base-adapter.md; real time only).
        #[arg(long, default_value = "sim")]
        source: String,
        /// `--source robot`: where the base adapter listens (JSON lines over TCP; keep it on localhost).
        #[arg(long, default_value = "127.0.0.1:7100", value_name = "ADDR")]
        base_listen: String,
        /// `--source robot`: scans from the adapter's client (`adapter`) or a VLP-16 on UDP
        /// (`vlp16-udp`, or `vlp16-udp=ADDR`; default 0.0.0.0:2368).
        #[arg(long, default_value = "adapter")]
        lidar: String,
        /// `--source robot`: the grid's lower-left corner `X,Y` in the odometry frame, metres
        /// (default: a 51.2 m grid centred on the first odometry pose).
        #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
        origin: Option<String>,
        #[command(flatten)]
        run: RunArgs,
        /// Override a controller parameter sent to the node, e.g. `--set w_dist_per_m=2`.
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// Change the simulated robot (`--source sim`), e.g. `--sim speed_mps=0.3` or `--sim camera_range_m=8`
        /// (repeatable; `lives params` lists them). The camera, the LiDAR's range and the body's
        /// size also set the controller's model of them; a `--set` then changes the model alone.
        #[arg(long = "sim", value_name = "NAME=VALUE")]
        sim: Vec<String>,
        /// The simulator waits for the node each tick (the node must run with --lockstep too).
        #[arg(long)]
        lockstep: bool,
        /// Send each scan in segments of this many beams (1-128; protocol v2 `ScanSegment`)
        /// instead of one frame: for a noisy line, where small frames survive and a 2.7 kB scan
        /// frame does not. 0: whole scans.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u16).range(0..=128))]
        scan_segment_beams: u16,
        /// Print one JSON object (result and link health).
        #[arg(long)]
        json: bool,
        /// Record what crosses the link (pose, scan, the node's labels, goals, detection, status)
        /// to an MCAP file that Foxglove opens (docs/recording.md).
        #[arg(long, value_name = "FILE.mcap")]
        record: Option<PathBuf>,
    },
    /// Train the map-free scan classifier (LabelPoseNet, f32, CPU) on a dataset; writes a safetensors checkpoint.
    /// (Built with `--features train`.)
    #[cfg(feature = "train")]
    Train {
        /// The dataset directory (`lives dataset --out DIR`).
        #[arg(long)]
        data: PathBuf,
        /// Where to write the f32 checkpoint.
        #[arg(long, default_value = host::train::DEFAULT_CHECKPOINT_PATH)]
        out: PathBuf,
        /// Passes over the training samples (the paper: 20–50 on a GPU; 10 epochs took 5.5–7 min on ~43 k samples here).
        #[arg(long, default_value_t = host::train::DEFAULT_EPOCHS)]
        epochs: usize,
        /// Samples per optimiser step (the paper: 4096).
        #[arg(long, default_value_t = host::train::DEFAULT_BATCH)]
        batch: usize,
        /// Adam learning rate.
        #[arg(long, default_value_t = 1e-3)]
        lr: f64,
        /// Seed of the initialisation, shuffling and label flips.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Fraction of history labels sign-flipped in training.
        #[arg(long, default_value_t = 0.1)]
        flip: f64,
        /// Train without the label history (all label inputs zero): the ablation.
        #[arg(long)]
        no_label_history: bool,
        /// Fraction of samples whose label history is the model's own rollout (0 = the paper's teacher forcing).
        #[arg(long, default_value_t = 0.5)]
        self_feedback: f64,
        /// Fraction of samples whose label history is all zero.
        #[arg(long, default_value_t = 0.05)]
        history_dropout: f64,
        /// Added to the diagonal of the encoders' 897 × 897 weights at initialisation (0: PyTorch's default init).
        #[arg(long, default_value_t = 1.0)]
        init_diag: f32,
        /// Train only on steps with 8 predecessors (the paper), not on the bootstrap steps too.
        #[arg(long)]
        no_bootstrap: bool,
        /// Use at most this many training samples (a seeded subset), for quick runs.
        #[arg(long)]
        max_samples: Option<usize>,
        /// Continue from this checkpoint instead of a fresh initialisation.
        #[arg(long)]
        resume: Option<PathBuf>,
        /// The range (mm) that normalises to 1; longer ranges clamp (written into the blob).
        #[arg(long, default_value_t = 30_000)]
        range_max_mm: u32,
        /// Start the scan convolution as this weight on the newest scan's centre tap, zero elsewhere (0: PyTorch's init).
        #[arg(long, default_value_t = 0.0)]
        scan_conv_init: f32,
        /// First epoch whose self-feedback histories are a rollout of the current model (1 when resuming a trained model).
        #[arg(long, default_value_t = 2)]
        own_history_from_epoch: usize,
        /// Initial bias of the label encoder's linear layer (0: PyTorch's init; 2 starts label_enc near +1 everywhere).
        #[arg(long, default_value_t = 0.0)]
        label_bias_init: f32,
        /// Inverse-range scan inputs: min(1, range_max_mm / r), no return 0, dropouts filled from the previous beam.
        #[arg(long)]
        inverse_range: bool,
        /// Epochs with the encoders' 897 × 897 weights trained as circulant matrices (one kernel for every beam), before full training.
        #[arg(long, default_value_t = 0)]
        circulant_epochs: usize,
        /// Loss weight of non-map beams (map beams 1).
        #[arg(long, default_value_t = 1.0)]
        non_map_weight: f32,
        /// Cosine learning-rate decay to lr / 20 over the run.
        #[arg(long)]
        lr_decay: bool,
    },
    /// Train the geometric classifier (per-beam shape features of the newest scan and its own
    /// earlier outputs, an int8 MLP; docs/model-card-geo.md), quantise it, evaluate it through the
    /// firmware on the dataset's validation split and in the built-in buildings, write the blob
    /// and a model card. (Built with `--features train`.)
    #[cfg(feature = "train")]
    TrainGeo {
        /// The dataset directory (`lives dataset --out DIR`; procedural worlds only).
        #[arg(long)]
        data: PathBuf,
        /// Where to write the int8 blob.
        #[arg(long, default_value = "firmware/model/lives-geo-int8.bin")]
        out: PathBuf,
        /// Where to write the model card (Markdown).
        #[arg(long)]
        card: Option<PathBuf>,
        /// Passes over the training samples.
        #[arg(long, default_value_t = 6)]
        epochs: usize,
        /// Initial SGD learning rate (divided by 1 + epoch).
        #[arg(long, default_value_t = 0.02)]
        lr: f32,
        /// Seed of the initialisation and shuffles.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Train on every N-th step of the training split.
        #[arg(long, default_value_t = 7)]
        step_stride: usize,
        /// … and every N-th labelled beam of those steps.
        #[arg(long, default_value_t = 5)]
        beam_stride: usize,
        /// Seconds of random walk in each built-in world and scenario for the unseen-building figures.
        #[arg(long, default_value_t = 60.0)]
        unseen_seconds: f64,
        /// Train only the scan-only model (the label-history inputs stay zero).
        #[arg(long)]
        no_label_history: bool,
        /// The history model trains on every N-th training episode, rolled out through the firmware.
        #[arg(long, default_value_t = 4)]
        history_episode_stride: usize,
        /// Probability of negating each label-history input in training (the paper: 10 %).
        #[arg(long, default_value_t = 0.1)]
        flip: f64,
        /// DAgger rounds of the history model (each rolls out the current model and retrains on the pool).
        #[arg(long, default_value_t = 3)]
        dagger_rounds: usize,
        /// The tanh table's input range: the largest hidden pre-activation seen, at most this.
        #[arg(long, default_value_t = host::train_geo::DEFAULT_PRE_CLIP)]
        pre_clip: f32,
    },
    /// Per-point accuracy of an int8 classifier blob (either format) through the firmware,
    /// autoregressive as on the robot, in each built-in building and scenario (never in a
    /// dataset), against the ground-truth labeller. (Built with `--features train`.)
    #[cfg(feature = "train")]
    ClassifierEval {
        /// The blob (default: the committed geometric model).
        #[arg(long, default_value = "firmware/model/lives-geo-int8.bin")]
        model: PathBuf,
        /// Seconds of random walk in each built-in world and scenario.
        #[arg(long, default_value_t = 60.0)]
        seconds: f64,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Calibrate the decision bias of a model without label history on a dataset's validation
    /// split: scores shifts of the scan encoder's linear bias, writes the best as a checkpoint.
    /// (Built with `--features train`.)
    #[cfg(feature = "train")]
    CalibrateBias {
        /// The f32 checkpoint.
        #[arg(long)]
        checkpoint: PathBuf,
        /// The dataset whose validation split decides (procedural worlds only).
        #[arg(long)]
        data: PathBuf,
        /// Where to write the shifted checkpoint.
        #[arg(long)]
        out: PathBuf,
        /// Candidate shifts, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "-0.5,-0.25,0,0.25,0.5,0.75,1,1.25,1.5,1.75,2,2.5,3")]
        deltas: Vec<f32>,
    },
    /// Quantise a checkpoint to the int8 blob the firmware runs, evaluate it, and write the model card.
    /// (Built with `--features train`.)
    #[cfg(feature = "train")]
    Quantise {
        /// The f32 checkpoint (`lives train --out`).
        #[arg(long, default_value = host::train::DEFAULT_CHECKPOINT_PATH)]
        checkpoint: PathBuf,
        /// The dataset whose validation split calibrates and evaluates (default: the one the checkpoint was trained on).
        #[arg(long)]
        data: Option<PathBuf>,
        /// Where to write the blob.
        #[arg(long, default_value = host::train::DEFAULT_BLOB_PATH)]
        out: PathBuf,
        /// Where to write the model card (`-` for none).
        #[arg(long, default_value = host::train::DEFAULT_CARD_PATH)]
        card: String,
        /// A second checkpoint (trained with or without --no-label-history) for the label-history ablation.
        #[arg(long)]
        ablation: Option<PathBuf>,
        /// Calibration inputs (steps of an autoregressive float run over the validation split).
        #[arg(long, default_value_t = 256)]
        calibration: usize,
        /// Seconds of random walk per built-in world and scenario for the unseen-world accuracy (0: skip).
        #[arg(long, default_value_t = 60.0)]
        unseen_seconds: f64,
        /// A Markdown file appended to the model card under "Notes".
        #[arg(long)]
        notes: Option<PathBuf>,
    },
    /// Golden traces of the serial link: record the host → core stream of a simulated search,
    /// or replay one through the core and print a digest of every answer (docs/mcu.md).
    #[command(subcommand)]
    Trace(TraceCmd),
    /// Reproduce the paper's Table I: every planner over the built-in worlds and scenarios,
    /// N trials each, in parallel; writes the table (Markdown, JSON, CSV) and plots.
    Eval {
        /// Trials per planner and setting (seeds 1..=N: start pose, target placement, people, noise).
        #[arg(long, default_value_t = 10)]
        trials: u64,
        /// Built-in worlds, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "apartment,office,hallway")]
        worlds: Vec<String>,
        /// Scenarios, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "easy,hard")]
        scenarios: Vec<Scenario>,
        /// Planners, comma-separated (`lives` runs the embedded int8 classifier). Default: every
        /// planner `--planner` knows, the last first (today rrt, explore-lite, nearest,
        /// multisensor, lives-gt, lives).
        #[arg(long, value_delimiter = ',')]
        planners: Vec<PlannerChoice>,
        /// Worker threads (default: the machine's cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Output directory: table.md, results.json, results.csv, times.png, trajectories/.
        #[arg(long, default_value = "out/eval")]
        out: PathBuf,
        /// Skip the trajectory pictures.
        #[arg(long)]
        no_pictures: bool,
        /// Override a controller parameter for every planner (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// Change the simulated robot, e.g. `--sim speed_mps=0.3` or `--sim camera_range_m=8`
        /// (repeatable; `lives params` lists them). The camera, the LiDAR's range and the body's
        /// size also set the controller's model of them; a `--set` then changes the model alone.
        #[arg(long = "sim", value_name = "NAME=VALUE")]
        sim: Vec<String>,
        /// The simulated robot: `calibrated` (the camera's reach calibrated on the paper's
        /// multisensor baseline, docs/experiments/camera-calibration.md) or `short` (a 4 m
        /// camera). `--sim` then changes it further.
        #[arg(long, default_value = "calibrated")]
        robot: Robot,
        /// Also run N held-out procedural worlds (seeds 1000001.., which `lives tune` and
        /// `lives dataset` refuse), one trial each, alternately easy and hard: the rows
        /// `heldout easy` and `heldout hard`. 0 runs none.
        #[arg(long, default_value_t = 100)]
        heldout: u64,
    },
    /// Tune planner parameters on procedurally generated worlds only (never the built-in ones):
    /// scores every combination of the `--grid` values by mean time to find / time limit.
    Tune {
        /// How many random worlds: `--world random --seed F..F+N-1`, F = `--first-world`.
        #[arg(long, default_value_t = 48)]
        worlds: u64,
        /// The first random world's seed. Choose values on one range, then confirm them on
        /// another that played no part in the choice, e.g. `--first-world 193 --worlds 192`.
        #[arg(long, default_value_t = 1)]
        first_world: u64,
        /// Planners the score averages over, comma-separated (`lives` runs the committed geometric
        /// classifier, as in `lives eval`).
        #[arg(long, value_delimiter = ',', default_value = "lives-gt,multisensor")]
        planners: Vec<PlannerChoice>,
        /// Settings of each random world, comma-separated: `easy` (the suitcase 2.5–8 m from the
        /// start, a shorter limit) and `hard` (in another room); see `--world random --scenario`.
        #[arg(long, value_delimiter = ',', default_value = "easy,hard")]
        scenarios: Vec<Scenario>,
        /// A parameter and its candidate values, e.g. `--grid w_dist_per_m=0.5,1,2` (repeatable).
        #[arg(long, value_name = "NAME=V1,V2,...", required = true)]
        grid: Vec<String>,
        /// Worker threads (default: the machine's cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Write the ranking as JSON here.
        #[arg(long, default_value = "out/tune.json")]
        out: PathBuf,
    },
    /// List the controller parameters `--set` accepts, with their defaults.
    Params(host::overrides::ParamsArgs),
    /// Replay a recorded log through the controller (no base to move): CARMEN logs (FLASER,
    /// ROBOTLASER1, ODOM; plain or gzip) and ROS 2 bags (MCAP or sqlite3) (docs/replay.md).
    Replay(host::replay::ReplayArgs),
    /// Score a LiDAR map against a reference: walls recovered, phantom walls, free-space leak
    /// (a replayed log against its own poses or another log; a simulated search against the true
    /// world), and pose errors on ground-truth relations (docs/mapcheck.md).
    Mapcheck(host::mapcheck::MapcheckArgs),
    /// Write a ROS 2 MCAP bag from a CARMEN log as a robot records one: LaserScan with +inf
    /// readings, odometry starting a few scans late, a rotated laser mount (host::export_bag).
    ExportBag(host::export_bag::ExportBagArgs),
    /// List the built-in worlds, or print one as a world file.
    Worlds {
        /// Print this built-in world (or `random`) as TOML.
        #[arg(long)]
        export: Option<String>,
        /// The scenario of the world `--export` prints: easy or hard.
        #[arg(long, default_value = "easy")]
        scenario: Scenario,
        /// The seed of `--export random` (which building it generates).
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Time the core's stages on a realistic, partly explored 512 × 512 map (host wall clock).
    Bench {
        /// Repetitions per stage (the median is reported).
        #[arg(long, default_value_t = 30)]
        reps: usize,
        /// Virtual seconds of search before measuring (how explored the map is).
        #[arg(long, default_value_t = 120.0)]
        explore_s: f64,
        /// Also time whole simulated searches (apartment hard, seeds 1–5, `lives-gt` and `lives`) against real time.
        #[arg(long)]
        searches: bool,
    },
    /// VLP-16 LiDAR: decode a capture (.pcap or raw payloads) or listen on UDP (docs/vlp16.md).
    #[command(subcommand)]
    Lidar(host::sensors::LidarCmd),
}

#[derive(Subcommand)]
enum TraceCmd {
    /// Record the first --ticks lockstep batches of a simulated search (bridge ↔ node in memory).
    Record {
        #[command(flatten)]
        run: RunArgs,
        /// Where to write the trace.
        #[arg(long)]
        out: PathBuf,
        /// Ticks (lockstep batches) to record.
        #[arg(long, default_value_t = 150)]
        ticks: u32,
        /// Send the simulator's labels with the scans instead of running the core's classifier
        /// (embedded model) on them.
        #[arg(long)]
        labels: bool,
    },
    /// Replay a trace through a fresh lockstep node and print `R record t_us ticks len crc32` per
    /// record. A damaged trace replays as far as its records are good, then the error goes to
    /// stderr: exit status 1 (2 when no record is good).
    Replay {
        /// The trace file.
        file: PathBuf,
        /// Also print every message of the trace and of the node's answers.
        #[arg(long)]
        decode: bool,
    },
}

/// `println!` that does not panic when stdout is closed early (`lives search | head -1`).
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

/// The world `name` names, its report name, and the scenario it was loaded in: `None` for a
/// world file, which holds one scenario of its own.
fn load_world(name: &str, scenario: Scenario, seed: u64) -> Result<(String, World, Option<Scenario>), String> {
    if name == "random" {
        return Ok((format!("random-{seed}"), World::random_scenario(seed, scenario), Some(scenario)));
    }
    if let Some(w) = World::builtin(name, scenario) {
        return Ok((name.to_string(), w, Some(scenario)));
    }
    let path = std::path::Path::new(name);
    if path.extension().is_some_and(|e| e == "toml") || path.exists() {
        // Reports name the world as the file does (`name = ...`, else the file's name).
        let w = World::load(path).map_err(|e| e.to_string())?;
        return Ok((w.name.clone(), w, None));
    }
    Err(format!("unknown world `{name}`: expected one of {}, `random`, or a .toml world file", World::builtin_names().join(", ")))
}

/// The search `--world`, `--scenario`, `--planner` and `--seed` describe. A world file holds one
/// scenario of its own: `--scenario` with one is refused rather than ignored, and reports say
/// `file` where a built-in world says `easy` or `hard`.
fn load_spec(run: &RunArgs) -> Result<SearchSpec, String> {
    let scenario = run.scenario.unwrap_or(Scenario::Easy);
    let (name, w, loaded_in) = load_world(&run.world, scenario, run.seed)?;
    if loaded_in.is_none() && run.scenario.is_some() {
        return Err(format!("--scenario applies to the built-in and random worlds; the world file {} holds its own scenario", run.world));
    }
    let mut spec = SearchSpec::new(&name, w, scenario, run.planner, run.seed);
    spec.scenario = loaded_in;
    Ok(spec)
}

/// The human-readable summary of a search: `FOUND apartment easy lives seed 1: found in …`.
fn result_line(r: &search::SearchResult) -> String {
    // A search that runs out of places to look ends early; like the paper, it counts as the
    // limit (`time_s`), but the line says when it stopped.
    let when = if r.outcome == "exhausted" {
        let stopped = r.ticks as f64 * search::TICK_US as f64 / 1e6;
        format!("exhausted (nothing left to explore) at {stopped:.1} s, counted as the limit ({:.0} s)", r.time_limit_s)
    } else {
        format!("{} in {:.1} s (limit {:.0} s)", r.outcome, r.time_s, r.time_limit_s)
    };
    format!(
        "{} {} {} {} seed {}: {when}, path {:.1} m, {} ticks, {} goals",
        if r.found { "FOUND" } else { "NOT FOUND" },
        r.world,
        r.scenario,
        r.planner,
        r.seed,
        r.path_m,
        r.ticks,
        r.goals
    )
}

fn progress_bar(len: u64) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template("{spinner} simulated {pos}/{len} s [{bar:40}] {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb
}

fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// A progress bar counting searches (hidden when stderr is not a terminal).
fn count_bar() -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(0);
    pb.set_style(
        ProgressStyle::with_template("{spinner} searches {pos}/{len} [{bar:40}] {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb
}

fn write_file(path: &std::path::Path, text: &str) -> Result<(), String> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Applies `--robot` (a named simulated robot), `--sim` (changes to it, and to the controller's
/// model of its sensors), then `--set`
/// (the controller alone, so it may still change that model).
fn configure_spec(spec: &mut SearchSpec, robot: Option<Robot>, set: &[String], sim: &[String]) -> Result<(), String> {
    if let Some(r) = robot {
        r.apply(spec)?;
    }
    for a in sim {
        host::overrides::apply_sim(&mut spec.sim, &mut spec.controller, a)?;
    }
    for a in set {
        host::overrides::apply(&mut spec.controller, a)?;
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn eval_cmd(
    trials: u64,
    worlds: &[String],
    scenarios: &[Scenario],
    planners: &[PlannerChoice],
    threads: Option<usize>,
    out: &std::path::Path,
    no_pictures: bool,
    set: &[String],
    sim: &[String],
    robot: Robot,
    heldout: u64,
) -> Result<ExitCode, String> {
    use host::eval;
    if trials == 0 {
        return Err("--trials must be at least 1".into());
    }
    let configure = |spec: &mut SearchSpec| configure_spec(spec, Some(robot), set, sim);
    let mut specs = eval::eval_specs(worlds, scenarios, planners, trials, firmware::classifier::EMBEDDED_GEO_MODEL, configure)?;
    specs.extend(eval::heldout_specs(heldout, planners, firmware::classifier::EMBEDDED_GEO_MODEL, configure)?);
    let pb = count_bar();
    pb.set_length(specs.len() as u64);
    let t0 = Instant::now();
    let threads_n = threads.unwrap_or_else(cores);
    let mut results = eval::run_batch(&specs, threads_n, |n| pb.set_position(n as u64))?;
    pb.finish_and_clear();
    let searches_s = t0.elapsed().as_secs_f64();
    eval::attach_oracles(&specs, &mut results, threads_n);
    let wall = t0.elapsed().as_secs_f64();
    let oracles_s = wall - searches_s;
    let cells = eval::summarise(&results);
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into());
    let command = std::env::args().map(|a| if a.contains(' ') { format!("'{a}'") } else { a }).collect::<Vec<_>>().join(" ");
    let table = eval::markdown_table(&cells);
    let claims = eval::claims(&results).unwrap_or_default();
    let heldout_note = if heldout > 0 {
        format!(
            "The held-out rows: {heldout} procedural worlds (`World::random_scenario`, seeds {}–{}, alternately easy and hard; \
             seeds `lives tune` and `lives dataset` refuse), one trial each; their limits are each world's own.\n\n",
            eval::HELDOUT_FIRST_SEED,
            eval::HELDOUT_FIRST_SEED + heldout - 1
        )
    } else {
        String::new()
    };
    let md = format!(
        "Robot: `{robot}` (camera {} m).\n\n{table}\n{heldout_note}{claims}\nCommand: `{command}` · commit {commit} · {} searches in {searches_s:.0} s and their oracles in {oracles_s:.0} s on {threads_n} threads ({wall:.0} s).\n",
        robot.camera_range_m(),
        results.len(),
    );
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    write_file(&out.join("table.md"), &md)?;
    write_file(&out.join("results.csv"), &eval::csv(&cells))?;
    let json =
        serde_json::json!({ "command": command, "commit": commit, "robot": robot, "wall_s": wall, "summary": cells, "trials": results });
    write_file(&out.join("results.json"), &serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?)?;
    // Time-to-find distributions: one panel per setting, one column per planner.
    let mut panels = Vec::new();
    let mut seen: Vec<(String, String)> = Vec::new();
    for c in &cells {
        let key = (c.world.clone(), c.scenario.clone());
        if seen.contains(&key) {
            continue;
        }
        seen.push(key);
        let columns = cells
            .iter()
            .filter(|d| d.world == c.world && d.scenario == c.scenario)
            .map(|d| (d.planner.as_str(), d.times_s.clone()))
            .collect();
        panels.push(host::render::StripPanel {
            title: format!("{} {} (limit {:.0} s)", c.world, c.scenario, c.time_limit_s),
            y_max: c.time_limit_s,
            columns,
        });
    }
    let times_png = out.join("times.png");
    host::render::write_strip_plot(&times_png, &format!("time to find, {trials} trials (failure = limit)"), "s", &panels)
        .map_err(|e| format!("{}: {e}", times_png.display()))?;
    if !no_pictures {
        // One trajectory picture per planner and setting, all for seed 1.
        let dir = out.join("trajectories");
        std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for spec in specs.iter().filter(|s| s.seed == 1) {
            let run = search::try_run(spec, |_| {}).map_err(|e| format!("{e}"))?;
            let r = &run.result;
            let title = format!(
                "{} {} · {} · seed 1 · {}",
                r.world,
                r.scenario,
                r.planner,
                if r.found { format!("FOUND in {:.1} s", r.time_s) } else { "NOT FOUND".into() }
            );
            let path = dir.join(format!("{}-{}-{}.png", r.world, r.scenario, r.planner));
            host::picture::write_png(&run, &path, &title).map_err(|e| format!("{}: {e}", path.display()))?;
        }
    }
    say!("{md}");
    say!(
        "written: {0}/table.md, {0}/results.json, {0}/results.csv, {0}/times.png{1}",
        out.display(),
        if no_pictures { "" } else { ", trajectories/" }
    );
    Ok(ExitCode::SUCCESS)
}

/// Every option or positional that takes a value accepts a negative number as its value
/// (`--max-range -1`, `--seed -3`), which the command then range-checks like any other; without
/// this clap took `-1` for an unknown flag (issue 29).
fn negatives_as_values(cmd: clap::Command) -> clap::Command {
    cmd.mut_args(|a| if a.get_action().takes_values() { a.allow_negative_numbers(true) } else { a }).mut_subcommands(negatives_as_values)
}

fn main() -> ExitCode {
    // A controller core is 1.4 MiB (docs/architecture.md, "Memory budget"), built by value
    // before it is boxed; the worker threads of `eval`, `tune`, `dataset` and the bridge need
    // more stack than Rust's 2 MiB default for that. Set before any thread is spawned (the
    // standard library reads it once); a value the user set is kept.
    if std::env::var_os("RUST_MIN_STACK").is_none() {
        std::env::set_var("RUST_MIN_STACK", (32usize << 20).to_string());
    }
    let matches = negatives_as_values(Cli::command()).get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> Result<ExitCode, String> {
    match cli.command {
        Cmd::Search { run, png, json, trace, trace_candidates, model, set, sim, robot, record } => {
            let mut spec = load_spec(&run)?;
            spec.trace = trace || trace_candidates.is_some();
            spec.trace_candidates = trace_candidates.unwrap_or(0);
            configure_spec(&mut spec, Some(robot), &set, &sim)?;
            let pb = progress_bar(spec.world.time_limit_s as u64);
            let t0 = Instant::now();
            // The committed geometric classifier (docs/model-card-geo.md) unless `--model`; only
            // `lives` runs it.
            if model.is_some() && !spec.planner.uses_classifier() {
                return Err(format!("--model is the classifier `lives` runs; `{}` runs none", spec.planner));
            }
            spec.model = host::model::model_option(model.as_deref(), false)?;
            let mut recorder =
                record.as_ref().map(|p| host::record::Recorder::create(p, Default::default())).transpose().map_err(|e| e.to_string())?;
            let (run, recorded) = host::record::record_search(&spec, recorder.as_mut(), |t| pb.set_position(t as u64)).map_err(|e| {
                format!("{}: the model does not validate: {e}", model.as_ref().map(|p| p.display().to_string()).unwrap_or_default())
            })?;
            let wall = t0.elapsed().as_secs_f64();
            pb.finish_and_clear();
            let mut recording = None;
            if let (Some(rec), Some(path)) = (recorder, &record) {
                recording = Some(recorded.and_then(|()| rec.finish()).map_err(|e| format!("{}: {e}", path.display()))?);
            }
            let r = &run.result;
            if let Some(path) = &png {
                let title = format!(
                    "{} {} · {} · seed {} · {} · path {:.1} m",
                    r.world,
                    r.scenario,
                    r.planner,
                    r.seed,
                    if r.found {
                        format!("FOUND in {:.1} s", r.time_s)
                    } else {
                        format!("NOT FOUND ({}, limit {:.0} s)", r.outcome, r.time_limit_s)
                    },
                    r.path_m
                );
                host::picture::write_png(&run, path, &title).map_err(|e| format!("writing {}: {e}", path.display()))?;
            }
            if json {
                say!("{}", serde_json::to_string(r).map_err(|e| e.to_string())?);
            } else {
                let sim_s = r.ticks as f64 * search::TICK_US as f64 / 1e6;
                say!("{}; {:.1} s simulated in {:.2} s ({:.0}x real time)", result_line(r), sim_s, wall, sim_s / wall.max(1e-9));
                if let Some(m) = r.motion {
                    let lidar =
                        r.lidar_saw_target_s.map_or("never saw the target".to_string(), |t| format!("first saw the target at {t:.1} s"));
                    let reach = match (r.found, r.target_in_camera_reach_s) {
                        (false, Some(t)) => format!("; it was within the camera's reach at {t:.1} s, but the camera did not look that way (or saw too little of it)"),
                        _ => String::new(),
                    };
                    say!(
                        "time: {:.1} s moving, {:.1} s turning, {:.1} s still; the LiDAR {lidar}{reach}",
                        m.moving_s,
                        m.turning_s,
                        m.still_s
                    );
                }
                if let Some(x) = &r.sim {
                    say!(
                        "robot (--robot {robot}{}): {} m/s, {} rad/s; LiDAR {} m, noise {} m, dropouts {}; camera {} m, {}°, detects at {} of the outline; body {} m",
                        if sim.is_empty() { "" } else { " --sim" },
                        x.speed_mps,
                        x.turn_rate_rps,
                        x.lidar_max_range_m,
                        x.range_noise_std_m,
                        x.dropout_prob,
                        x.camera_range_m,
                        x.camera_fov_deg,
                        x.detect_min_visible_fraction,
                        x.robot_radius_m
                    );
                }
                if let Some(c) = r.classifier {
                    say!(
                        "labels: the classifier agreed with the simulator's truth on {:.1} % of {} beams (non-map: {:.1} % found, {:.1} % of its non-map labels right)",
                        100.0 * c.accuracy,
                        c.beams,
                        100.0 * c.nonmap_recall,
                        100.0 * c.nonmap_precision
                    );
                }
                if let Some(p) = &png {
                    say!("picture: {}", p.display());
                }
                if let (Some(p), Some(s)) = (&record, &recording) {
                    say!("recording: {} ({} messages on {} topics)", p.display(), s.total_messages(), s.messages.len());
                }
            }
            Ok(if r.found { ExitCode::SUCCESS } else { ExitCode::from(1) })
        }
        Cmd::Worlds { export, scenario, seed } => {
            match export {
                Some(name) => {
                    let (_, w, _) = load_world(&name, scenario, seed)?;
                    say!("{}", w.to_toml_string().trim_end());
                }
                None => {
                    for n in World::builtin_names() {
                        for s in [Scenario::Easy, Scenario::Hard] {
                            if let Some(w) = World::builtin(n, s) {
                                let [lo, hi] = w.bounds;
                                say!(
                                    "{n:10} {s:5} {:5.1} x {:5.1} m, time limit {:4.0} s, {} obstacles, {} people",
                                    hi[0] - lo[0],
                                    hi[1] - lo[1],
                                    w.time_limit_s,
                                    w.obstacles.len(),
                                    w.people.len()
                                );
                            }
                        }
                    }
                    say!("random     (any seed: --world random --seed N)");
                }
            }
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Dataset { out, worlds, episodes_per_world, seed, min_episode_s, max_episode_s, labeller, threads, furniture_density } => {
            use host::dataset::{generate_with, DatasetSpec};
            use host::labeller::LabellerConfig;
            if host::eval::overlaps_heldout(seed, seed.saturating_add(u64::from(worlds.max(1)) - 1)) {
                return Err(format!(
                    "worlds from seed {seed} overlap the held-out worlds {}..{} that `lives eval --heldout` reports; pick other seeds",
                    host::eval::HELDOUT_FIRST_SEED,
                    host::eval::HELDOUT_FIRST_SEED + host::eval::HELDOUT_MAX_WORLDS
                ));
            }
            let mut spec = DatasetSpec::new(&out, seed, worlds, episodes_per_world);
            spec.episode_min_s = min_episode_s;
            spec.episode_max_s = max_episode_s;
            spec.threads = threads;
            spec.density = match furniture_density[..] {
                [d] => [d, d],
                [lo, hi] => [lo, hi],
                _ => return Err(format!("--furniture-density takes LO,HI or one value, not {} values", furniture_density.len())),
            };
            spec.labeller = match labeller.as_str() {
                "sim" => LabellerConfig::default(),
                "spot" => LabellerConfig::spot(),
                other => return Err(format!("unknown labeller `{other}` (expected sim or spot)")),
            };
            spec.command = std::env::args().collect::<Vec<_>>().join(" ");
            let pb = progress_bar(worlds as u64);
            let t0 = Instant::now();
            let sum = generate_with(&spec, |p| {
                pb.set_position(p.worlds_done as u64);
            })
            .map_err(|e| e.to_string())?;
            pb.finish_and_clear();
            let wall = t0.elapsed().as_secs_f64();
            let a = &sum.agreement;
            say!(
                "dataset {}: {} worlds x {} episodes, {:.0} s simulated in {:.1} s",
                sum.out_dir.display(),
                worlds,
                episodes_per_world,
                sum.simulated_s,
                wall
            );
            say!(
                "  train: {} records from {} worlds, {:.1} MB; val: {} records from {} worlds {:?}, {:.1} MB",
                sum.train_records,
                sum.train_worlds.len(),
                sum.train_bytes as f64 / 1e6,
                sum.val_records,
                sum.val_worlds.len(),
                sum.val_worlds,
                sum.val_bytes as f64 / 1e6
            );
            say!(
                "  labeller vs simulator truth: map/non-map {:.2} % (wall->LTF {:.2} %, non-map->STF/DF {:.2} %)",
                a.map_accuracy() * 100.0,
                a.map_recall() * 100.0,
                a.non_map_recall() * 100.0
            );
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Soak { minutes, sim_hours, pull_every, pull_for, noise, sample_every, growth_kib, seed, json } => {
            let positive = |name: &str, v: f64| match v.is_finite() && v > 0.0 {
                true => Ok(std::time::Duration::from_secs_f64(v)),
                false => Err(format!("--{name} {v}: expected a positive number")),
            };
            if !(0.0..=0.5).contains(&noise) {
                return Err(format!("--noise {noise}: expected a probability from 0 to 0.5"));
            }
            if !(sim_hours.is_finite() && sim_hours >= 0.0) {
                return Err(format!("--sim-hours {sim_hours}: expected hours, 0 or more"));
            }
            let opts = host::soak::SoakOptions {
                wall: positive("minutes", minutes * 60.0)?,
                sim_hours,
                pull_every: positive("pull-every", pull_every)?,
                pull_for: positive("pull-for", pull_for)?,
                noise,
                sample_every: positive("sample-every", sample_every)?,
                lives: std::env::current_exe().map_err(|e| format!("cannot find this program: {e}"))?,
                seed,
                growth_kib,
            };
            let report = host::soak::run(&opts, &mut |line| eprintln!("{line}")).map_err(|e| format!("soak: {e}"))?;
            if let Some(path) = &json {
                let text = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
                std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
            }
            println!("{}", host::soak::summary(&report));
            if report.failures.is_empty() {
                Ok(ExitCode::SUCCESS)
            } else {
                for f in &report.failures {
                    eprintln!("FAIL: {f}");
                }
                Ok(ExitCode::from(1))
            }
        }
        Cmd::Node { port, baud, lockstep, seconds, model, no_model } => {
            use host::link::{run_node, NodeOptions, SerialLink, TimeMode};
            let blob = host::model::model_option(model.as_deref(), no_model)?;
            let classifier = match (&model, blob) {
                (Some(p), _) => p.display().to_string(),
                (None, Some(_)) => "geometric (embedded)".to_string(),
                (None, None) => "none".to_string(),
            };
            use std::sync::atomic::{AtomicBool, Ordering};
            let mode = if lockstep { TimeMode::Lockstep } else { TimeMode::RealTime };
            let mut link = SerialLink::open(&port, baud).unwrap_or_else(|e| {
                eprintln!("waiting for {} ({e})", port.display());
                SerialLink::by_path(&port, baud)
            });
            let stop = AtomicBool::new(false);
            let report = std::thread::scope(|s| {
                if let Some(secs) = seconds {
                    let stop = &stop;
                    s.spawn(move || {
                        std::thread::sleep(std::time::Duration::from_secs_f64(secs.max(0.0)));
                        stop.store(true, Ordering::Relaxed);
                    });
                }
                run_node(&mut link, firmware::Config::DEFAULT, NodeOptions { model: blob, ..NodeOptions::new(mode) }, &stop)
            })
            .map_err(|e| format!("the classifier model: {e}"))?;
            let c = &report.counters;
            say!(
                "{}",
                serde_json::json!({
                    "mode": format!("{:?}", report.mode),
                    "classifier": classifier,
                    "ticks": c.ticks,
                    "frames_in": report.link.frames_ok,
                    "rejected": report.link.dropped(),
                    "link": report.link,
                    "frames_sent": c.frames_sent,
                    "bytes_sent": c.bytes_sent,
                    "bytes_received": c.bytes_received,
                    "goals_sent": c.goals_sent,
                    "configs_applied": c.configs_applied,
                    "configs_invalid": c.configs_invalid,
                    "resets": c.resets,
                    "config_error": report.config_error.map(|e| e.to_string()),
                    "lockstep_incomplete": c.lockstep_incomplete,
                    "lockstep_repeats": c.lockstep_repeats,
                    "tick_us": report.tick_us,
                    "overruns": report.overruns,
                    "io_errors": report.io_errors,
                    "reconnects": report.reconnects,
                    "wall_s": report.wall_s,
                })
            );
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Bridge { port, baud, source, run, set, sim, lockstep, scan_segment_beams, json, record, base_listen, lidar, origin } => {
            use host::link::{run_bridge, BridgeOptions, SerialLink, Source, TimeMode};
            if source == "robot" && !sim.is_empty() {
                return Err("--sim changes the simulated robot; it has no meaning with `--source robot`".into());
            }
            if source == "robot" {
                let opts = host::link::robot::CliOptions {
                    port,
                    baud,
                    planner: run.planner,
                    set,
                    lockstep,
                    json,
                    record,
                    base_listen,
                    lidar,
                    origin,
                };
                return host::link::robot::run_cli(opts);
            }
            if source != "sim" {
                return Err(format!("unknown source `{source}` (`sim` or `robot`)"));
            }
            let mut spec = load_spec(&run)?;
            configure_spec(&mut spec, None, &set, &sim)?;
            if spec.planner.uses_classifier() {
                // As `lives search`: the scans go without labels and the node's classifier (the
                // committed geometric one unless `lives node --model` says otherwise) labels
                // them; the bridge stops with a clear error if the node has none.
                spec.model = Some(firmware::classifier::EMBEDDED_GEO_MODEL);
            }
            let mode = if lockstep { TimeMode::Lockstep } else { TimeMode::RealTime };
            let mut link = SerialLink::open(&port, baud).unwrap_or_else(|e| {
                eprintln!("waiting for {} ({e})", port.display());
                SerialLink::by_path(&port, baud)
            });
            let stop = std::sync::atomic::AtomicBool::new(false);
            let recording = record.as_ref().map(|p| host::record::SharedRecording::create(p)).transpose().map_err(|e| e.to_string())?;
            let opts = BridgeOptions {
                scan_segment_beams: scan_segment_beams as usize,
                want_labels: recording.is_some(),
                observer: recording.as_ref().map(|r| r.observer()),
                ..BridgeOptions::new(mode)
            };
            let run = run_bridge(&mut link, Source::Sim(spec), &opts, &stop).map_err(|e| e.to_string())?;
            if let (Some(rec), Some(path)) = (recording, &record) {
                rec.finish().map_err(|e| format!("{}: {e}", path.display()))?;
            }
            let (r, st) = (&run.result, &run.stats);
            if json {
                let goals: Vec<_> = run.goals.iter().map(|((x, y), h)| serde_json::json!([x, y, h.0])).collect();
                say!("{}", serde_json::json!({ "result": r, "link": st, "goals": goals, "wall_s": run.wall_s }));
            } else {
                let ticks = r.ticks.max(1) as f64;
                say!("{}; {:.2} s wall", result_line(r), run.wall_s);
                say!(
                    "link: sent {} frames / {} B ({:.0} B per tick), received {} frames / {} B, rejected {} ({})",
                    st.frames_sent,
                    st.bytes_sent,
                    st.bytes_sent as f64 / ticks,
                    st.frames_received,
                    st.bytes_received,
                    st.rejected,
                    st.decoder
                );
                say!(
                    "link: {} retries, {} hellos, {} losses, {} reopenings, {} io errors; round trip p50 {:.0} us p95 {:.0} us; batch round trip p50 {:.0} us p95 {:.0} us; scan {} B in {} frame(s)",
                    st.retries,
                    st.hellos_sent,
                    st.link_losses,
                    st.reconnects,
                    st.io_errors,
                    st.link_rtt_us.p50,
                    st.link_rtt_us.p95,
                    st.batch_rtt_us.p50,
                    st.batch_rtt_us.p95,
                    st.scan_frame_bytes,
                    st.scan_frames
                );
                if let Some(n) = &st.node_status {
                    say!("node: {:?}, {} ticks, {} scans, rejected {} ({})", n.mode, n.ticks, n.scans, n.link.dropped(), n.link);
                }
            }
            Ok(if r.found { ExitCode::SUCCESS } else { ExitCode::from(1) })
        }
        #[cfg(feature = "train")]
        Cmd::ClassifierEval { model, seconds, json } => {
            let blob = std::fs::read(&model).map_err(|e| format!("{}: {e}", model.display()))?;
            let eps = host::train::unseen_episodes(seconds, 1).map_err(|e| e.0)?;
            let per = host::train_geo::evaluate_blob_per_episode(&blob, &eps).map_err(|e| format!("{}: {}", model.display(), e.0))?;
            let mut pooled = host::train::Confusion::default();
            per.iter().for_each(|(_, c)| pooled.merge(c));
            let mean = per.iter().map(|(_, c)| c.accuracy()).sum::<f64>() / per.len().max(1) as f64;
            let set = |name: &str, c: &host::train::Confusion| {
                serde_json::json!({
                    "set": name, "beams": c.total(), "accuracy": c.accuracy(), "always_map": c.always_map(),
                    "map_recall": c.map_recall(), "non_map_recall": c.non_map_recall(),
                })
            };
            let format = if firmware::classifier::geo::GeoView::is_geo(&blob) { "LVGM (geometric)" } else { "LIVM (LabelPoseNet)" };
            if json {
                let sets: Vec<_> = per.iter().map(|(n, c)| set(n, c)).collect();
                say!(
                    "{}",
                    serde_json::json!({
                        "model": model.display().to_string(), "format": format, "random_walk_s": seconds,
                        "per_world": sets, "pooled": set("pooled", &pooled), "mean_over_worlds": mean,
                    })
                );
            } else {
                say!("{} ({format}), int8 through the firmware, {seconds:.0} s random walk per world:", model.display());
                say!("| world | beams | accuracy | always map | map recall | non-map recall |\n|---|---|---|---|---|---|");
                for (n, c) in per.iter().chain(std::iter::once(&("pooled".to_string(), pooled))) {
                    say!("| {n} | {} | {:.2} % | {} |", c.total(), 100.0 * c.accuracy(), rate_cells(c));
                }
                say!("mean over the {} worlds: {:.2} %", per.len(), 100.0 * mean);
            }
            Ok(ExitCode::SUCCESS)
        }
        #[cfg(feature = "train")]
        Cmd::TrainGeo {
            data,
            out,
            card,
            epochs,
            lr,
            seed,
            step_stride,
            beam_stride,
            unseen_seconds,
            no_label_history,
            history_episode_stride,
            flip,
            dagger_rounds,
            pre_clip,
        } => {
            let history = (!no_label_history).then_some((history_episode_stride, flip, dagger_rounds));
            train_geo_command(&data, &out, card.as_deref(), epochs, lr, seed, step_stride, beam_stride, unseen_seconds, history, pre_clip)
        }
        #[cfg(feature = "train")]
        Cmd::Train {
            data,
            out,
            epochs,
            batch,
            lr,
            seed,
            flip,
            no_label_history,
            self_feedback,
            history_dropout,
            no_bootstrap,
            init_diag,
            max_samples,
            resume,
            range_max_mm,
            inverse_range,
            label_bias_init,
            own_history_from_epoch,
            scan_conv_init,
            circulant_epochs,
            non_map_weight,
            lr_decay,
        } => {
            let cfg = host::train::TrainConfig {
                data,
                epochs,
                batch,
                lr,
                seed,
                flip,
                label_history: !no_label_history,
                bootstrap: !no_bootstrap,
                self_feedback,
                history_dropout,
                init_diag,
                max_samples,
                range_max_mm,
                inverse_range,
                label_bias_init,
                own_history_from_epoch,
                scan_conv_init,
                circulant_epochs,
                non_map_weight,
                lr_decay,
                command: std::env::args().collect::<Vec<_>>().join(" "),
            };
            let progress = |e: &host::train::EpochLog| {
                say!(
                    "epoch {:3}: loss {:.4}, val accuracy teacher-forced {:.2} %, autoregressive {:.2} %, {:.0} s",
                    e.epoch,
                    e.train_loss,
                    100.0 * e.val_accuracy,
                    100.0 * e.val_ar_accuracy,
                    e.train_s
                )
            };
            let (model, log) = match resume {
                Some(p) => {
                    let (init, _) = host::train::load_checkpoint(&p).map_err(|e| e.to_string())?;
                    host::train::train_from(&cfg, init, progress)
                }
                None => host::train::train(&cfg, progress),
            }
            .map_err(|e| e.to_string())?;
            host::train::save_checkpoint(&model, Some(&log), &out).map_err(|e| e.to_string())?;
            say!("trained {} epochs on {} samples in {:.0} s; checkpoint {}", log.epochs.len(), log.samples[0], log.total_s, out.display());
            Ok(ExitCode::SUCCESS)
        }
        #[cfg(feature = "train")]
        Cmd::CalibrateBias { checkpoint, data, out, deltas } => {
            let t0 = Instant::now();
            let (mut model, log) = host::train::load_checkpoint(&checkpoint).map_err(|e| e.to_string())?;
            let eps = host::train::load_split(&data, host::dataset::Split::Val).map_err(|e| e.to_string())?;
            let cands = host::train::calibrate_scan_bias(&model, &eps, &deltas).map_err(|e| e.to_string())?;
            say!(
                "| delta | float accuracy, all steps | warm steps | map recall | non-map recall | always map |\n|---|---|---|---|---|---|"
            );
            for c in &cands {
                let a = &c.accuracy;
                say!(
                    "| {} | {:.2} % | {:.2} % | {:.2} % | {:.2} % | {:.2} % |",
                    c.delta,
                    100.0 * a.all.accuracy(),
                    100.0 * a.warm.accuracy(),
                    100.0 * a.all.map_recall(),
                    100.0 * a.all.non_map_recall(),
                    100.0 * a.all.always_map()
                );
            }
            let best =
                cands.iter().max_by(|a, b| a.accuracy.all.accuracy().total_cmp(&b.accuracy.all.accuracy())).ok_or("no candidate shifts")?;
            model.scan.fc_b.iter_mut().for_each(|v| *v += best.delta);
            host::train::save_checkpoint(&model, log.as_ref(), &out).map_err(|e| e.to_string())?;
            say!(
                "best shift {} ({:.2} %); checkpoint {} ({:.0} s)",
                best.delta,
                100.0 * best.accuracy.all.accuracy(),
                out.display(),
                t0.elapsed().as_secs_f64()
            );
            Ok(ExitCode::SUCCESS)
        }
        #[cfg(feature = "train")]
        Cmd::Quantise { checkpoint, data, out, card, ablation, calibration, unseen_seconds, notes } => {
            let mut cfg = host::train::QuantiseConfig::new(checkpoint);
            cfg.data = data;
            cfg.out = out;
            cfg.card = (card != "-").then(|| PathBuf::from(card));
            cfg.ablation = ablation;
            cfg.calibration = calibration;
            cfg.unseen_seconds = unseen_seconds;
            cfg.command = std::env::args().collect::<Vec<_>>().join(" ");
            cfg.notes = match notes {
                Some(p) => Some(std::fs::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()))?),
                None => None,
            };
            let r = host::train::quantise_and_evaluate(&cfg, |line| say!("{line}")).map_err(|e| e.to_string())?;
            say!(
                "int8 per-point accuracy (autoregressive, as on the robot): validation {:.2} %{}",
                100.0 * r.val.int8_ar_raw.all.accuracy(),
                r.unseen.as_ref().map(|u| format!(", built-in worlds {:.2} %", 100.0 * u.int8_ar_raw.all.accuracy())).unwrap_or_default()
            );
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Trace(TraceCmd::Record { run, out, ticks, labels }) => {
            let mut spec = load_spec(&run)?;
            if !labels {
                spec.model = Some(firmware::classifier::EMBEDDED_MODEL);
            }
            let bytes = host::trace::record(spec, ticks)?;
            std::fs::write(&out, &bytes).map_err(|e| format!("{}: {e}", out.display()))?;
            say!("{}: {} bytes, {} ticks", out.display(), bytes.len(), ticks);
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Trace(TraceCmd::Replay { file, decode }) => {
            let bytes = std::fs::read(&file).map_err(|e| format!("{}: {e}", file.display()))?;
            // A damaged trace: its good records are printed, then the error (status 1; 2 when
            // not even the first record is good).
            let (printed, error) = if decode {
                let r = host::trace::decode(&bytes).map_err(|e| format!("{}: {e}", file.display()))?;
                for line in &r.records {
                    say!("{line}");
                }
                (!r.records.is_empty(), r.error)
            } else {
                let r = host::trace::replay(&bytes).map_err(|e| format!("{}: {e}", file.display()))?;
                for d in &r.records {
                    say!("{}", host::trace::digest_line(d));
                }
                (!r.records.is_empty(), r.error)
            };
            match error {
                Some(e) if printed => {
                    eprintln!("error: {}: {e}", file.display());
                    Ok(ExitCode::from(1))
                }
                Some(e) => Err(format!("{}: {e}", file.display())),
                None => Ok(ExitCode::SUCCESS),
            }
        }
        Cmd::Eval { trials, worlds, scenarios, planners, threads, out, no_pictures, set, sim, robot, heldout } => {
            let planners = if planners.is_empty() { PlannerChoice::ALL.into_iter().rev().collect() } else { planners };
            eval_cmd(trials, &worlds, &scenarios, &planners, threads, &out, no_pictures, &set, &sim, robot, heldout)
        }
        Cmd::Tune { worlds, first_world, planners, scenarios, grid, threads, out } => {
            let grid: Vec<(String, Vec<String>)> = grid.iter().map(|g| host::eval::parse_grid_axis(g)).collect::<Result<_, _>>()?;
            // Reject unknown names and bad values before spending minutes.
            for a in host::eval::grid_assignments(&grid) {
                let mut c = firmware::Config::DEFAULT;
                for x in &a {
                    host::overrides::apply(&mut c, x)?;
                }
            }
            if worlds == 0 {
                return Err("--worlds must be at least 1".into());
            }
            let last_world = first_world.checked_add(worlds - 1).ok_or("--first-world + --worlds is past the last seed")?;
            if host::eval::overlaps_heldout(first_world, last_world) {
                return Err(format!(
                    "worlds {first_world}..={last_world} overlap the held-out worlds {}..{} that `lives eval --heldout` reports; tune on others",
                    host::eval::HELDOUT_FIRST_SEED,
                    host::eval::HELDOUT_FIRST_SEED + host::eval::HELDOUT_MAX_WORLDS
                ));
            }
            if scenarios.is_empty() || planners.is_empty() {
                return Err("--scenarios and --planners need at least one value each".into());
            }
            let pb = count_bar();
            let t0 = Instant::now();
            let scores = host::eval::tune(
                &grid,
                &planners,
                &scenarios,
                first_world..=last_world,
                threads.unwrap_or_else(cores),
                firmware::classifier::EMBEDDED_GEO_MODEL,
                |n, total| {
                    pb.set_length(total as u64);
                    pb.set_position(n as u64);
                },
            )?;
            pb.finish_and_clear();
            say!("| rank | assignment | mean time / limit | 95 % CI | found | paired Δ vs defaults |\n|---|---|---|---|---|---|");
            let label = |sets: &[String]| if sets.is_empty() { "(defaults)".to_string() } else { sets.join(" ") };
            for (i, sc) in scores.iter().enumerate() {
                say!(
                    "| {} | {} | {:.3} | ± {:.3} | {:.0} % | {:+.3} ± {:.3} |",
                    i + 1,
                    label(&sc.sets),
                    sc.mean_normalised_time,
                    sc.ci95,
                    100.0 * sc.success_rate,
                    sc.vs_defaults,
                    sc.vs_defaults_ci95
                );
            }
            if let Some(best) = scores.first().filter(|b| !b.sets.is_empty()) {
                say!(
                    "best on random worlds {first_world}..={last_world}, {} ({} searches each, {:.0} s): --set {}",
                    scenarios.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(" and "),
                    best.searches,
                    t0.elapsed().as_secs_f64(),
                    best.sets.join(" --set ")
                );
            } else {
                say!("best on random worlds {first_world}..={last_world}: the defaults ({:.0} s)", t0.elapsed().as_secs_f64());
            }
            write_file(&out, &serde_json::to_string_pretty(&scores).map_err(|e| e.to_string())?)?;
            say!("ranking: {}", out.display());
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Replay(args) => host::replay::run_command(&args),
        Cmd::Mapcheck(args) => host::mapcheck::run_command(&args, |world, scenario, planner, seed| {
            load_spec(&RunArgs { world: world.to_string(), scenario, planner, seed })
        }),
        Cmd::ExportBag(args) => host::export_bag::run_command(&args),
        Cmd::Params(args) => host::overrides::run_params(&args),
        Cmd::Bench { reps, explore_s, searches } => {
            host::bench::run(reps, explore_s, searches);
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Lidar(cmd) => host::sensors::run(cmd),
    }
}

/// "always map | map recall | non-map recall" cells of a classifier table row, in per cent.
#[cfg(feature = "train")]
fn rate_cells(c: &host::train::Confusion) -> String {
    format!("{:.2} % | {:.2} % | {:.2} %", 100.0 * c.always_map(), 100.0 * c.map_recall(), 100.0 * c.non_map_recall())
}

/// `lives train-geo`: train, quantise, evaluate through the firmware, write the blob and a card.
#[cfg(feature = "train")]
#[allow(clippy::too_many_arguments)]
fn train_geo_command(
    data: &std::path::Path,
    out: &std::path::Path,
    card: Option<&std::path::Path>,
    epochs: usize,
    lr: f32,
    seed: u64,
    step_stride: usize,
    beam_stride: usize,
    unseen_seconds: f64,
    history: Option<(usize, f64, usize)>,
    pre_clip: f32,
) -> Result<ExitCode, String> {
    use host::dataset::Split;
    use host::train::{load_split, unseen_episodes, Confusion};
    use host::train_geo::{evaluate_float, evaluate_int8, quantise, rollout_samples, samples, train, GeoTrainConfig};
    let t0 = Instant::now();
    let e = |e: host::train::TrainError| e.0;
    let train_eps = load_split(data, Split::Train).map_err(e)?;
    let val_eps = load_split(data, Split::Val).map_err(e)?;
    let unseen = unseen_episodes(unseen_seconds, 1).map_err(e)?;
    let tr = samples(&train_eps, step_stride, beam_stride);
    let va = samples(&val_eps, 10, 3);
    say!("{} training samples (every {step_stride}th step, every {beam_stride}th beam), {} validation samples", tr.len(), va.len());
    let cfg = GeoTrainConfig { epochs, lr, seed };
    let mut log = Vec::new();
    let m = train(&cfg, &tr, |ep, loss, m| {
        let v = evaluate_float(m, &va);
        say!(
            "epoch {}: loss {loss:.4}, validation (float, sampled) {:.2} % (always map {:.2} %)",
            ep + 1,
            100.0 * v.accuracy(),
            100.0 * v.always_map()
        );
        log.push((ep + 1, loss, v.accuracy()));
    })
    .map_err(e)?;
    let q = quantise(&m, &tr[..tr.len().min(200_000)], pre_clip).map_err(e)?;
    // With the label history: a second model trained on the first one's own autoregressive
    // outputs (run through the firmware) as its history; the first is the ablation.
    let (m, q, ablation, history_note) = match history {
        Some((episode_stride, flip, rounds)) => {
            // DAgger: each round rolls the current model out through the firmware (its own
            // outputs become the history), adds those samples to the pool and trains a new model
            // on the pool; the first round rolls out the scan-only model.
            let subset: Vec<host::train::Episode> = train_eps.iter().step_by(episode_stride.max(1)).cloned().collect();
            let mut pool: Vec<host::train_geo::Sample> = Vec::new();
            let (mut cur_m, mut cur_q) = (m.clone(), q.clone());
            for round in 0..rounds.max(1) {
                let more = rollout_samples(&cur_q.blob, &subset, 2, beam_stride, flip, seed + round as u64).map_err(e)?;
                pool.extend(more);
                say!(
                    "label history, round {}: {} samples in the pool ({} training episodes rolled out)",
                    round + 1,
                    pool.len(),
                    subset.len()
                );
                cur_m = train(&cfg, &pool, |ep, loss, _| {
                    say!("history model, round {}, epoch {}: loss {loss:.4}", round + 1, ep + 1);
                    log.push((ep + 1, loss, f64::NAN));
                })
                .map_err(e)?;
                cur_q = quantise(&cur_m, &pool[..pool.len().min(200_000)], pre_clip).map_err(e)?;
            }
            let note = format!(
                "the label history: a second model whose inputs add the model's own earlier outputs for the same direction (one step earlier, and the 8-step weighted average), trained by DAgger over {rounds} round(s): each round runs the current model autoregressively through the firmware on every {episode_stride}th training episode (every 2nd step sampled, each history input negated with probability {flip}), adds the samples to the pool ({} in the end) and trains a new model on the pool, the same epochs and learning rate",
                pool.len()
            );
            (cur_m, cur_q, Some(q.blob), note)
        }
        None => (m, q, None, "no label history (its two inputs are zero)".to_string()),
    };
    let train_s = t0.elapsed().as_secs_f64();
    let (val_int8, val_agree) = evaluate_int8(&q.blob, &val_eps, Some(&m)).map_err(e)?;
    let (un_int8, un_agree) = evaluate_int8(&q.blob, &unseen, Some(&m)).map_err(e)?;
    let ablation = match &ablation {
        Some(blob) => Some((evaluate_int8(blob, &val_eps, None).map_err(e)?.0, evaluate_int8(blob, &unseen, None).map_err(e)?.0)),
        None => None,
    };
    if let Some(dir) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    std::fs::write(out, &q.blob).map_err(|e| format!("{}: {e}", out.display()))?;
    let crc = firmware::classifier::geo::GeoView::parse(&q.blob).map(|v| v.crc()).unwrap_or(0);
    let row = |name: &str, c: &Confusion, agree: Option<f64>| {
        format!(
            "| {name} | {} | **{:.2} %** | {} | {:.2} % |",
            c.total(),
            100.0 * c.accuracy(),
            rate_cells(c),
            100.0 * agree.unwrap_or(0.0)
        )
    };
    let table = [
        "| set | labelled beams | int8 accuracy | always map | map recall | non-map recall | float/int8 agreement |".to_string(),
        "|---|---|---|---|---|---|---|".to_string(),
        row(&format!("validation (unseen random worlds, {} episodes)", val_eps.len()), &val_int8, val_agree),
        row(&format!("built-in apartment, office, hallway ({} random walks of {unseen_seconds:.0} s)", unseen.len()), &un_int8, un_agree),
    ]
    .join("\n");
    let ablation_md = match &ablation {
        Some((v, u)) => format!(
            "\n\nWithout the label history (the scan-only model, int8, the same runs): validation {:.2} % ({:+.2} points with it), built-in buildings {:.2} % ({:+.2} points with it).",
            100.0 * v.accuracy(),
            100.0 * (val_int8.accuracy() - v.accuracy()),
            100.0 * u.accuracy(),
            100.0 * (un_int8.accuracy() - u.accuracy())
        ),
        None => String::new(),
    };
    let table = format!("{table}{ablation_md}");
    say!("{table}");
    say!("blob {} ({} bytes, CRC-32 {crc:08x}); {:.0} s in all", out.display(), q.blob.len(), t0.elapsed().as_secs_f64());
    if let Some(card) = card {
        let epochs_md: String = log
            .iter()
            .map(|(ep, l, a)| {
                if a.is_nan() {
                    format!("| {ep} (history model) | {l:.4} | |\n")
                } else {
                    format!("| {ep} | {l:.4} | {:.2} % |\n", 100.0 * a)
                }
            })
            .collect();
        let cmd = std::env::args().collect::<Vec<_>>().join(" ");
        let dataset_cmd = std::fs::read_to_string(data.join("meta.json"))
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
            .and_then(|m| m["generator"]["command"].as_str().map(str::to_string))
            .unwrap_or_else(|| "(not recorded in meta.json)".into());
        let text = format!(
            "# Model card: geometric scan classifier (`LVGM`, int8)\n\n\
             Generated by `lives train-geo`; every number below was measured by that command.\n\n\
             - command: `{cmd}`\n\
             - blob: `{}`, {} bytes, CRC-32 `{crc:08x}`\n\
             - data: `{}` ({} training episodes, {} validation episodes; split by world), made by `{dataset_cmd}`\n\
             - training: {} samples, {epochs} epochs of SGD on the logistic loss, lr {lr} / (1 + epoch), seed {seed}; then {history_note}; {train_s:.0} s\n\
             - quantisation: hidden pre-activations calibrated on {} training samples, max |pre| {:.2}, table range ±{:.2}\n\n\
             | epoch | training loss | validation accuracy (float, sampled beams) |\n|---|---|---|\n{epochs_md}\n\
             Int8, run through the firmware classifier over every step (every labelled beam with a return):\n\n{table}\n\n\
             ## Notes\n\n\
             - **What it is.** Per-beam shape features of the newest scan, computed by the firmware with integers \
             (`firmware::classifier::geo`, docs/model-format.md): how far the point stands in front of the chord through \
             its neighbours 2 to 128 beams away on either side, the length of its run without a depth jump on each side and \
             where that run ends, and its inverse range; with two label-history inputs, a 23 → 48 → 1 MLP in int8. The float \
             model trains on the firmware's own features, so quantisation changes only the weights.\n\
             - **Why not the paper's network.** `LabelPoseNet` (docs/model-card.md) sees each beam through one 9 × 9 \
             convolution channel; it stays below \"always map\" in the built-in buildings (81.50 % against 84.27 %). The \
             front of a wardrobe looks like a wall over 9 beams; over 30–250 beams it stands in front of the wall behind it.\n\
             - **Label history.** As the paper's label encoder, the model reads its own earlier outputs for the same \
             direction (one step earlier, and the 8-step weighted average; the pose history turns each earlier row to the \
             beam that pointed the same way). Trained naively on a scan-only model's outputs as history it collapsed when its \
             own outputs came back (74.70 % in the built-in buildings, one round, measured while developing this); DAgger rounds, each rolling the current model out \
             through the firmware and retraining on the growing pool, fix that. The ablation line above is the scan-only \
             model, which is also the first stage of this command. The labels are the simulator-exact labeller's (0.1 m LTF \
             gate, docs/dataset.md), not ENML's 0.7 m.\n\
             - **Reproducing.** The dataset command above, then the command above; training, rollouts and quantisation are \
             single-threaded and seeded, so the blob is byte-identical run to run.\n",
            out.display(),
            q.blob.len(),
            data.display(),
            train_eps.len(),
            val_eps.len(),
            tr.len(),
            tr.len().min(200_000),
            q.max_pre,
            q.pre_range,
        );
        std::fs::write(card, text).map_err(|e| format!("{}: {e}", card.display()))?;
        say!("card {}", card.display());
    }
    Ok(ExitCode::SUCCESS)
}
