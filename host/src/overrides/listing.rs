//! `lives params`: the parameter tables as text, or as the Markdown of `docs/params.md`
//! (`lives params --markdown > docs/params.md`; a test fails while the committed file differs).

use super::{value, SimParam, SET_DEGREES, SET_SECONDS, SET_WEIGHTS, SIM_PARAMS};
use firmware::config::{ParamInfo, Unit, PARAMS};
use firmware::Config;
use std::process::ExitCode;

/// `lives params`.
#[derive(clap::Args, Debug, Clone)]
pub struct ParamsArgs {
    /// Print the tables as Markdown: the text of docs/params.md.
    #[arg(long)]
    pub markdown: bool,
}

/// Runs `lives params`.
pub fn run_params(args: &ParamsArgs) -> Result<ExitCode, String> {
    use std::io::Write as _;
    let text = if args.markdown { params_markdown() } else { params_text() };
    let _ = std::io::stdout().write_all(text.as_bytes());
    Ok(ExitCode::SUCCESS)
}

/// A table: a header and rows of cells.
struct Table {
    header: &'static [&'static str],
    rows: Vec<Vec<String>>,
}

impl Table {
    /// Aligned columns, indented by two spaces; the last column is not padded.
    fn text(&self) -> String {
        let mut widths = vec![0; self.header.len()];
        for row in std::iter::once(&self.header.iter().map(|h| h.to_string()).collect()).chain(&self.rows) {
            for (w, cell) in widths.iter_mut().zip(row) {
                *w = (*w).max(cell.chars().count());
            }
        }
        let line = |cells: &[String]| {
            let n = cells.len();
            let padded: Vec<String> =
                cells.iter().zip(&widths).enumerate().map(|(i, (c, &w))| if i + 1 < n { format!("{c:w$}") } else { c.clone() }).collect();
            format!("  {}\n", padded.join("  "))
        };
        let header: Vec<String> = self.header.iter().map(|h| h.to_string()).collect();
        std::iter::once(line(&header)).chain(self.rows.iter().map(|r| line(r))).collect()
    }

    /// A Markdown table.
    fn markdown(&self) -> String {
        let line = |cells: &[String]| format!("| {} |\n", cells.join(" | "));
        let header: Vec<String> = self.header.iter().map(|h| h.to_string()).collect();
        let rule = vec!["---".to_string(); header.len()];
        [line(&header), line(&rule)].into_iter().chain(self.rows.iter().map(|r| line(r))).collect()
    }
}

/// The values `p` may take: what `--set` takes (`set`), or what the core works with (the range
/// [`Config::validate`] holds it to, as its error writes it, or else its type's).
fn range(p: &ParamInfo, set: bool) -> String {
    match (set, p.unit) {
        (true, Unit::Weight) => return SET_WEIGHTS.into(),
        (true, Unit::Seconds) => return format!("{SET_SECONDS} s"),
        (true, Unit::Degrees) => return format!("{SET_DEGREES}°"),
        _ => {}
    }
    if let Some(allowed) = p.allowed {
        return allowed.to_string();
    }
    match p.unit {
        Unit::Count => format!("[{}, {}]", p.raw_range.0, p.raw_range.1),
        Unit::Flag => "true, false".into(),
        Unit::Planner => "`--planner`".into(),
        _ => "any".into(),
    }
}

/// The controller's parameters as rows: for the text, the `--set` ones or the rest; for Markdown,
/// all of them, with their wire numbers and types.
fn controller_rows(settable: bool, markdown: bool) -> Vec<Vec<String>> {
    let code = |s: &str| if markdown { format!("`{s}`") } else { s.to_string() };
    PARAMS
        .iter()
        .enumerate()
        .filter(|(_, p)| markdown || p.set_name.is_some() == settable)
        .map(|(i, p)| {
            let mut row = match markdown {
                true => vec![i.to_string(), code(p.field), p.set_name.map_or(String::new(), code)],
                false => vec![p.set_name.unwrap_or(p.field).to_string()],
            };
            row.extend([p.unit.symbol().into(), value(&Config::DEFAULT, p), range(p, settable && !markdown), p.summary.into()]);
            if markdown {
                row.push(p.wire.into());
            }
            row
        })
        .collect()
}

/// The simulator's settings as rows.
fn sim_rows(markdown: bool) -> Vec<Vec<String>> {
    let sim = crate::robot_model::default_sim();
    let rows = SIM_PARAMS.iter().map(|p: &SimParam| {
        let name = if markdown { format!("`{}`", p.name) } else { p.name.to_string() };
        vec![name, p.unit.into(), p.get(&sim), p.range_text(), p.summary.into()]
    });
    rows.collect()
}

const COLUMNS: &[&str] = &["NAME", "UNIT", "DEFAULT", "RANGE", "MEANING"];

/// `lives params`: what `--set` and `--sim` accept, with units, defaults and ranges, and the
/// controller's parameters fixed at build time.
pub fn params_text() -> String {
    let table = |rows| Table { header: COLUMNS, rows }.text();
    [
        "The controller (`--set NAME=VALUE` on search, eval, replay, bridge; a value outside the core's\n".to_string(),
        "range is refused and the error gives the range):\n\n".into(),
        table(controller_rows(true, false)),
        "\nThe simulated robot (`--sim NAME=VALUE` on search, eval, bridge --source sim):\n\n".into(),
        table(sim_rows(false)),
        "\nThe controller's other parameters, fixed at build time (`Config::DEFAULT`; a bridge sends them\n".into(),
        "to the robot's core in its `Config` message):\n\n".into(),
        table(controller_rows(false, false)),
        "\nEach is declared once: firmware/src/config/params.rs (the controller), host/src/overrides/sim.rs\n".into(),
        "(the simulated robot); the capacities are in firmware/src/capacity.rs. docs/params.md has them all.\n".into(),
    ]
    .concat()
}

/// `lives params --markdown`: the text of `docs/params.md`.
pub fn params_markdown() -> String {
    let controller =
        Table { header: &["#", "field", "`--set`", "unit", "default", "range", "meaning", "wire"], rows: controller_rows(true, true) };
    let sim = Table { header: &["`--sim`", "unit", "default", "range", "meaning"], rows: sim_rows(true) };
    [
        "# Parameters (generated by `lives params --markdown > docs/params.md`: do not edit)\n\n",
        "Every parameter is declared once: the controller's in the table of\n",
        "`firmware/src/config/params.rs` (which makes `firmware::Config`, its defaults, its checks and the\n",
        "wire's `ConfigMsg`), the simulated robot's in `host/src/overrides/sim.rs`. This file is their\n",
        "listing; a test fails while it differs from what the command prints.\n\n",
        "## The controller\n\n",
        "`#` is the field's number on the wire (`ConfigMsg::FIELDS`, by which `Error { ConfigInvalid }`\n",
        "names it; `docs/protocol.md`); *range* is what `Config::validate` holds it to (a configuration\n",
        "with a field outside it is refused, naming the field), or else what its type takes. A field\n",
        "with a `--set` name can be changed on the command line, in the unit given (search, eval, replay,\n",
        "bridge; `--set` also takes weights only in ",
        SET_WEIGHTS,
        ", seconds in ",
        SET_SECONDS,
        " and\n",
        "degrees in ",
        SET_DEGREES,
        "); the rest are fixed at build time (`Config::DEFAULT`) and sent to a\n",
        "robot's core in its `Config` message.\n\n",
        &controller.markdown(),
        "\n## The simulated robot\n\n",
        "`--sim NAME=VALUE` on search, eval and bridge --source sim. Defaults are the simulated robot's\n",
        "(`host::robot_model::default_sim`); a setting whose meaning says the controller's model follows\n",
        "also sets that part of the controller's configuration.\n\n",
        &sim.markdown(),
    ]
    .concat()
}
