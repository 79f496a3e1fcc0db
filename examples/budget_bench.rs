//! The frame budget on assets/scenes/budget.toml at one size: each effect's levels pinned (its
//! front) and what three budgets pick, printed as markdown. The measurement is
//! `hadou_cli::report::budget::section`, the code `hadou report` runs.
//!
//! cargo run --release --example budget_bench [-- --size 256x256] [--frames N]

use hadou::{Runtime, RuntimeOptions};
use hadou_cli::report::{budget, ReportOptions, Steps};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let arg = |name: &str| std::env::args().skip_while(|a| a != name).nth(1);
    let size = arg("--size").unwrap_or_else(|| "256x256".into());
    let (w, h) = size.split_once('x').ok_or("--size WIDTHxHEIGHT")?;
    let mut opts = ReportOptions::new(false);
    opts.effect_size = (w.parse()?, h.parse()?);
    opts.frames = arg("--frames").map(|f| f.parse()).transpose()?.unwrap_or(20);
    let mut runtime = Runtime::new(&RuntimeOptions::from_env())?;
    let info = runtime.device_info().clone();
    println!("device: {} ({})\n", info.name, info.driver);
    let mut show = |label: &str, done: usize, total: usize| eprintln!("[{done}/{total}] {label}");
    let mut steps = Steps::new(budget::steps(&opts), &mut show);
    let section = budget::section(&mut runtime, &opts, &mut steps).map_err(|e| format!("{e:?}"))?;
    println!("{}", section.markdown(2, "."));
    Ok(())
}
