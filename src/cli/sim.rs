//! `repro sim` and `repro bench`: run the event-driven simulator directly.

use crate::sim::{self, Drive, KickRate, Progress, RunSummary, SimConfig, Stage};
use crate::traj::Schedule;
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;

#[derive(Subcommand, Debug)]
pub enum Commands {
    /// Run one simulation (compress, relax, measure) and print its summary.
    Sim(SimArgs),
    /// Speed benchmark: driven steady state at phi = 0.78, eps = 0.9 for several N;
    /// one JSON summary per line.
    Bench(BenchArgs),
}

#[derive(Args, Debug)]
pub struct SimArgs {
    /// Number of disks.
    #[arg(long, default_value_t = 10_000, allow_negative_numbers = true, value_parser = parse_count)]
    pub n: usize,
    /// Packing fraction.
    #[arg(long, default_value_t = 0.78)]
    pub phi: f64,
    /// Coefficient of normal restitution, in (0, 1].
    #[arg(long, default_value_t = 0.9)]
    pub eps: f64,
    /// Radius ratio r2/r1 (1 = monodisperse).
    #[arg(long, default_value_t = 1.43)]
    pub radius_ratio: f64,
    /// Fraction of large disks.
    #[arg(long, default_value_t = 0.5)]
    pub fraction_large: f64,
    /// No driving (elastic gas with --eps 1, free cooling otherwise).
    #[arg(long)]
    pub no_drive: bool,
    /// Kick random pairs instead of neighbour pairs.
    #[arg(long, conflicts_with = "no_drive")]
    pub random_pairs: bool,
    /// What a kick moves: `pairs` (a particle and a neighbour, opposite
    /// momenta; paper H) or `single` (one particle; paper I with friction).
    #[arg(long, default_value = "pairs", value_parser = ["pairs", "single"], conflicts_with_all = ["no_drive", "random_pairs"])]
    pub drive: String,
    /// Viscous friction rate gamma (force -gamma m v on every particle).
    #[arg(long, default_value_t = 0.0)]
    pub gamma: f64,
    /// The temperature the driving holds (sets the kick amplitude by Eq. 7 of paper I).
    #[arg(long, default_value_t = 1.0)]
    pub temperature: f64,
    /// Box aspect ratio Ly / Lx.
    #[arg(long, default_value_t = 1.0)]
    pub aspect: f64,
    /// Hard walls per axis, `x,y` from `wall` or `periodic` (e.g. `periodic,wall`:
    /// a channel with walls at y = 0 and Ly).
    #[arg(long, default_value = "periodic,periodic", value_parser = parse_walls)]
    pub walls: [bool; 2],
    /// Pull an intruder (paper I: R_0 = 2, m_0 = 4, placed first) with this
    /// force along +x, from the start of the relaxation on.
    #[arg(long)]
    pub intruder_force: Option<f64>,
    /// How the force acts: `exact` (the curved path, root finder) or `kicks`
    /// (paper I's train of momentum kicks F dt).
    #[arg(long, default_value = "exact", value_parser = ["exact", "kicks"], requires = "intruder_force")]
    pub intruder_force_mode: String,
    /// With `--intruder-force-mode kicks`: kicks per unit time in units of the
    /// bath's Enskog collision frequency (paper I: 10^4).
    #[arg(long, default_value_t = 1e4, requires = "intruder_force")]
    pub intruder_kick_rate_factor: f64,
    /// The intruder's start, `x,y` as fractions of the box sides (default: at random).
    #[arg(long, value_parser = parse_start, requires = "intruder_force")]
    pub intruder_start: Option<[f64; 2]>,
    /// Measured (production) time after relaxation.
    #[arg(long, default_value_t = 10.0)]
    pub time: f64,
    /// Driven relaxation time before measuring.
    #[arg(long, default_value_t = 10.0)]
    pub relax: f64,
    /// Relative radius growth rate of the Lubachevsky-Stillinger compression.
    #[arg(long, default_value_t = 0.02)]
    pub compression_rate: f64,
    /// Kick rate rule: `balanced` (tuned during relaxation to hold T = 1),
    /// `enskog` (the Enskog collision frequency at --temperature), `enskog*F`
    /// (F times it), or a number (kicks each particle receives per unit time).
    /// Default: balanced without friction, enskog with it.
    #[arg(long, value_parser = parse_kick_rate)]
    pub kick_rate: Option<KickRate>,
    /// Random seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// System sizes.
    #[arg(long, value_delimiter = ',', default_value = "10000,100000,1000000")]
    pub n: Vec<usize>,
    /// Measured time per size (after relaxation).
    #[arg(long, default_value_t = 2.0)]
    pub time: f64,
    /// Relaxation time per size.
    #[arg(long, default_value_t = 2.0)]
    pub relax: f64,
    /// Radius growth rate of the compression that prepares each state: faster
    /// than `repro sim`'s default, because only the steady state after the
    /// relaxation is timed (at N = 10^6 the default compression alone takes
    /// minutes).
    #[arg(long, default_value_t = 0.1)]
    pub compression_rate: f64,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Measure checkpoints instead: bytes per particle, the time to write one
    /// and to resume from it, and paired runs of `--time` with and without a
    /// synchronisation every `--every` (docs/sim.md, "Checkpoints").
    #[arg(long)]
    pub checkpoints: bool,
    /// Simulation time between the synchronisations of `--checkpoints`.
    #[arg(long, default_value_t = 0.5)]
    pub every: f64,
}

/// A number of disks: a positive integer (negative values reach here, not clap's
/// "unexpected argument", thanks to `allow_negative_numbers`).
fn parse_count(s: &str) -> Result<usize, String> {
    match s.parse::<i128>() {
        Ok(v) if v >= 1 && v <= usize::MAX as i128 => Ok(v as usize),
        _ => Err(format!("n must be a positive integer, got `{s}`")),
    }
}

fn parse_walls(s: &str) -> Result<[bool; 2], String> {
    let axis = |a: &str| match a.trim() {
        "wall" | "walls" => Ok(true),
        "periodic" => Ok(false),
        _ => Err(format!(
            "invalid walls `{s}`: use two of wall|periodic, e.g. periodic,wall"
        )),
    };
    match s.split(',').collect::<Vec<_>>()[..] {
        [x, y] => Ok([axis(x)?, axis(y)?]),
        _ => Err(format!(
            "invalid walls `{s}`: use two of wall|periodic, e.g. periodic,wall"
        )),
    }
}

fn parse_start(s: &str) -> Result<[f64; 2], String> {
    let bad = || format!("invalid start `{s}`: use x,y as fractions of the box, e.g. 0.1,0.5");
    match s
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Vec<_>>()[..]
    {
        [Ok(x), Ok(y)] => Ok([x, y]),
        _ => Err(bad()),
    }
}

fn parse_kick_rate(s: &str) -> Result<KickRate, String> {
    let bad = || format!("invalid kick rate `{s}`: use balanced, enskog, enskog*F or a number");
    match s {
        "balanced" => Ok(KickRate::Balanced),
        "enskog" => Ok(KickRate::Enskog { prefactor: 1.0 }),
        _ => match s.strip_prefix("enskog*") {
            Some(f) => f
                .parse()
                .map(|prefactor| KickRate::Enskog { prefactor })
                .map_err(|_| bad()),
            None => s.parse().map(KickRate::PerParticle).map_err(|_| bad()),
        },
    }
}

impl SimArgs {
    pub fn config(&self) -> SimConfig {
        SimConfig {
            n: self.n,
            phi: self.phi,
            eps: self.eps,
            radius_ratio: self.radius_ratio,
            fraction_large: self.fraction_large,
            drive: if self.no_drive {
                Drive::None
            } else if self.random_pairs {
                Drive::RandomPairs
            } else if self.drive == "single" {
                Drive::Single
            } else {
                Drive::NeighbourPairs
            },
            kick_rate: self.kick_rate.clone().unwrap_or(if self.gamma > 0.0 {
                KickRate::Enskog { prefactor: 1.0 }
            } else {
                KickRate::Balanced
            }),
            gamma: self.gamma,
            temperature: self.temperature,
            aspect: self.aspect,
            walls: self.walls,
            intruder: self.intruder_force.map(|f| sim::config::Intruder {
                force_mode: if self.intruder_force_mode == "kicks" {
                    sim::ForceMode::Kicks
                } else {
                    sim::ForceMode::Exact
                },
                kick_rate_factor: self.intruder_kick_rate_factor,
                start: self.intruder_start,
                ..sim::config::Intruder::paper(f)
            }),
            seed: self.seed,
            relax_time: self.relax,
            compression_rate: self.compression_rate,
            // No frames: only the summary is printed (and a frame of 4 x 10^6
            // disks would cost 64 MB).
            schedule: Schedule {
                start: self.time,
                origins: 0,
                origin_spacing: 0.0,
                lags: vec![],
            },
            ..SimConfig::default()
        }
    }
}

/// Run with a progress bar on a terminal.
fn run_with_progress(cfg: &SimConfig) -> anyhow::Result<RunSummary> {
    let bar = if std::io::stderr().is_terminal() {
        let b = ProgressBar::new(1000);
        b.set_style(
            ProgressStyle::with_template("{prefix:>10} [{bar:30}] {msg} (ETA {eta})")
                .expect("valid template")
                .progress_chars("=> "),
        );
        Some(b)
    } else {
        None
    };
    let stage = std::cell::Cell::new(None::<(Stage, f64)>);
    let report = |p: Progress| {
        let Some(b) = &bar else { return };
        // Each stage restarts the bar from the time it began.
        let start = match stage.get() {
            Some((s, t)) if s == p.stage => t,
            _ => {
                stage.set(Some((p.stage, p.time)));
                b.reset();
                b.set_prefix(format!("{:?}", p.stage).to_lowercase());
                p.time
            }
        };
        let frac = ((p.time - start) / (p.end - start).max(1e-300)).clamp(0.0, 1.0);
        b.set_position((frac * 1000.0) as u64);
        b.set_message(format!(
            "t = {:.2} / {:.2}, {:.2e} events/s",
            p.time, p.end, p.events_per_second
        ));
    };
    let out = sim::run(cfg, &report);
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    Ok(out?.1)
}

/// The summary as one JSON line, without the time series.
fn json_line(s: &RunSummary) -> anyhow::Result<String> {
    let mut v = serde_json::to_value(s)?;
    if let Some(o) = v.as_object_mut() {
        o.remove("series");
    }
    Ok(serde_json::to_string(&v)?)
}

pub fn run(c: Commands) -> anyhow::Result<()> {
    match c {
        Commands::Sim(a) => {
            // The production time becomes the frame-less schedule's start, whose
            // own error would not name the flag.
            anyhow::ensure!(
                a.time.is_finite() && a.time > 0.0,
                "--time {} is invalid: the production time must be positive",
                a.time
            );
            let s = run_with_progress(&a.config())?;
            if a.json {
                println!("{}", json_line(&s)?);
            } else {
                println!(
                    "n = {}, phi = {}, eps = {}, seed = {}",
                    s.n, s.phi, s.eps, s.seed
                );
                println!(
                    "measured over t = {} after relaxing {} (compression took {:.1})",
                    s.sim_time, s.relax_time, s.compress_time
                );
                println!(
                    "temperature = {:.4} +- {:.4} (fluctuation), halves {:.4} / {:.4}",
                    s.temperature,
                    s.temperature_std,
                    s.temperature_halves[0],
                    s.temperature_halves[1]
                );
                println!(
                    "temperature per species = {}",
                    s.species_temperature
                        .iter()
                        .map(|t| format!("{t:.4}"))
                        .collect::<Vec<_>>()
                        .join(" / ")
                );
                println!("Z = {:.4} +- {:.4}", s.z, s.z_err);
                if s.wall_collisions > 0 {
                    println!(
                        "wall pressure = {:.4} (x walls) / {:.4} (y walls), {} wall collisions",
                        s.wall_pressure[0], s.wall_pressure[1], s.wall_collisions
                    );
                }
                println!(
                    "collision rate = {:.4} per particle (Enskog {:.4}); kick rate = {:.4}",
                    s.collision_rate, s.enskog_collision_rate, s.kick_rate
                );
                println!(
                    "collisions = {}, kicks = {}, guard activations = {}",
                    s.collisions, s.kicks, s.guard_activations
                );
                println!(
                    "energy: injected {:.6e}, dissipated {:.6e}, friction {:.6e}; ledger error {:.1e}",
                    s.energy_injected,
                    s.energy_dissipated,
                    s.energy_friction,
                    s.energy_balance_error
                );
                if let Some(i) = &s.intruder {
                    println!(
                        "intruder (F = {}): mean velocity {:.4} / {:.4} (terminal F/(gamma m0) = {:.4}); bath drift {:.4} / {:.4} (F/(gamma M) = {:.4}); work of F {:.6e}; root finder {:.1} steps per call, {} re-predictions",
                        i.force,
                        i.velocity[0],
                        i.velocity[1],
                        i.terminal_velocity,
                        i.bath_drift[0],
                        i.bath_drift[1],
                        i.predicted_drift,
                        i.energy_work,
                        i.root_steps_per_call,
                        i.repredicts
                    );
                }
                println!(
                    "{:.3e} collisions/s, {:.1} CPU s, {:.1} MB peak RSS",
                    s.collisions_per_second,
                    s.cpu_seconds,
                    s.peak_rss_bytes as f64 / 1e6
                );
            }
            Ok(())
        }
        Commands::Bench(b) => {
            anyhow::ensure!(
                b.time.is_finite() && b.time > 0.0,
                "--time {} is invalid: the measured time must be positive",
                b.time
            );
            for &n in &b.n {
                let args = SimArgs {
                    n,
                    phi: 0.78,
                    eps: 0.9,
                    radius_ratio: 1.43,
                    fraction_large: 0.5,
                    no_drive: false,
                    random_pairs: false,
                    drive: "pairs".into(),
                    gamma: 0.0,
                    temperature: 1.0,
                    aspect: 1.0,
                    walls: [false, false],
                    intruder_force: None,
                    intruder_force_mode: "exact".into(),
                    intruder_kick_rate_factor: 1e4,
                    intruder_start: None,
                    time: b.time,
                    relax: b.relax,
                    compression_rate: b.compression_rate,
                    kick_rate: Some(KickRate::Balanced),
                    seed: b.seed,
                    json: true,
                };
                if b.checkpoints {
                    let c = crate::sim::run::checkpoint_cost::measure(
                        &args.config(),
                        b.relax,
                        b.time,
                        b.every,
                        &std::env::temp_dir(),
                    )?;
                    println!("{}", serde_json::to_string(&c)?);
                    continue;
                }
                let s = run_with_progress(&args.config())?;
                println!("{}", json_line(&s)?);
            }
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Commands, run};
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(subcommand)]
        c: Commands,
    }

    fn error_of(args: &[&str]) -> String {
        let cli = Cli::try_parse_from(std::iter::once("repro").chain(args.iter().copied()))
            .expect("arguments parse");
        run(cli.c).unwrap_err().to_string()
    }

    #[test]
    fn a_negative_n_is_named_a_bad_count_not_an_unexpected_argument() {
        for bad in ["-5", "0", "abc"] {
            let e = Cli::try_parse_from(["repro", "sim", "--n", bad])
                .err()
                .expect("must be refused")
                .to_string();
            assert!(e.contains("n must be a positive integer"), "{e}");
            assert!(!e.contains("unexpected argument"), "{e}");
        }
        assert!(Cli::try_parse_from(["repro", "sim", "--n", "200"]).is_ok());
    }

    #[test]
    fn a_non_positive_time_names_the_flag() {
        let e = error_of(&["sim", "--n", "200", "--time", "0"]);
        assert!(e.contains("--time 0 is invalid"), "{e}");
        let e = error_of(&["bench", "--n", "200", "--time=-1"]);
        assert!(e.contains("--time -1 is invalid"), "{e}");
    }

    #[test]
    fn impossible_friction_options_are_named() {
        let e = error_of(&["sim", "--n", "200", "--gamma=-1"]);
        assert!(e.contains("gamma = -1 is invalid"), "{e}");
        let e = error_of(&["sim", "--n", "200", "--drive", "single"]);
        assert!(e.contains("drive: single with gamma = 0"), "{e}");
        let e = error_of(&["sim", "--n", "200", "--temperature", "0"]);
        assert!(e.contains("temperature = 0 is invalid"), "{e}");
        let e = error_of(&[
            "sim",
            "--n",
            "200",
            "--walls",
            "wall,periodic",
            "--aspect",
            "100",
        ]);
        assert!(e.contains("cannot fit"), "{e}");
        let bad = Cli::try_parse_from(["repro", "sim", "--walls", "wall"]);
        assert!(bad.is_err_and(|e| e.to_string().contains("invalid walls")));
    }
}
