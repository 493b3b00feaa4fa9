//! `lives params`: the parameters `--set` and `--sim` accept, with their defaults.

use super::common::say;
use std::process::ExitCode;

pub fn run() -> Result<ExitCode, String> {
    let w = host::overrides::NAMES.iter().chain(host::overrides::SIM_NAMES).map(|n| n.0.len()).max().unwrap_or(0);
    say!("The controller (`--set NAME=VALUE` on search, eval, replay, bridge; a value outside the core's");
    say!("range is refused and the error gives the range):");
    say!();
    say!("  {:w$}  {:>8}  meaning", "NAME", "DEFAULT");
    for (name, what) in host::overrides::NAMES {
        let d = host::overrides::get(&firmware::Config::DEFAULT, name).unwrap_or_default();
        say!("  {name:w$}  {d:>8}  {what}");
    }
    say!();
    say!("The simulated robot (`--sim NAME=VALUE` on search, eval, bridge --source sim):");
    say!();
    say!("  {:w$}  {:>8}  meaning", "NAME", "DEFAULT");
    let sim = host::search::default_sim();
    for (name, what) in host::overrides::SIM_NAMES {
        let d = host::overrides::get_sim(&sim, name).unwrap_or_default();
        say!("  {name:w$}  {d:>8}  {what}");
    }
    say!();
    say!("Everything else is fixed at build time: firmware/src/config.rs (`Config::DEFAULT`) and");
    say!("firmware/src/capacity.rs.");
    Ok(ExitCode::SUCCESS)
}
