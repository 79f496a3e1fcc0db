//! The `hadou report` translucency table alone (ceilings, then the LUT at 25, 40, 56, 64, 128, peel
//! with the light maps of res 25 and 56, the seed's pair table at 16 and 25, and TSM at 512×512),
//! for docs/PERFORMANCE.md.
//!
//! cargo run --release --example translucency_table
fn main() {
    let mut runtime = hadou::Runtime::new(&hadou::RuntimeOptions::from_env()).expect("runtime");
    let mut opts = hadou_cli::report::ReportOptions::new(false);
    opts.voxel_res = vec![25, 40, 56, 64, 128];
    opts.peel_res = vec![25, 56];
    opts.pairs_res = vec![16, 25];
    opts.frames = 10;
    let mut show = |label: &str, _: usize, _: usize| eprintln!("{label}");
    let mut steps = hadou_cli::report::Steps::new(opts.step_count(), &mut show);
    let (_, ceilings) = hadou_cli::report::ceilings::section(&runtime, &opts, &mut steps).expect("ceilings");
    let section = hadou_cli::report::translucency::section(&mut runtime, &opts, &ceilings, &mut steps)
        .expect("translucency");
    println!("{}", section.markdown(2, "."));
}
