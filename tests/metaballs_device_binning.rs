//! The metaballs effect with its tile lists built on the device (`Metaballs::with_binning(
//! Binning::Device)`, the opt-in) renders every byte as the default host binning does: the colour
//! and the HDR, normal and depth AOVs of scenes with one group, 4,096 balls, a showcase world and
//! the dense fluid (a crowded group, cast streamed; its run flag on the device's lists:
//! tests/metaballs_binning.rs).

mod common;

use hadou::effect::{Binning, Effects, EnergyWave, Metaballs, Translucency};
use hadou::{Aov, FrameRequest};

fn render(scene: &str, binning: Binning) -> (Vec<u8>, Vec<u32>) {
    // hadou's own effects in their order, the metaballs configured.
    let effects = Effects::none()
        .with(Metaballs::with_binning(binning))
        .and_then(|e| e.with(Translucency))
        .and_then(|e| e.with(EnergyWave))
        .unwrap();
    let mut rt = common::runtime_with_effects(effects);
    rt.load_scene(hadou::builtin::load(scene.as_ref()).unwrap()).unwrap();
    let mut request = FrameRequest::new(160, 120);
    request.time = 1.5;
    request.aovs = vec![Aov::Hdr, Aov::Normal, Aov::Depth];
    let out = rt.render(&request).unwrap();
    let bits = request.aovs.iter().flat_map(|&a| out.aov(a).unwrap().data.iter().map(|v| v.to_bits()));
    let bits: Vec<u32> = bits.collect();
    let colour = out.color.clone().unwrap();
    common::assert_clean(&rt);
    (colour, bits)
}

#[test]
fn device_binning_renders_every_byte_as_host_binning() {
    for scene in
        ["builtin:metaballs", "builtin:metaballs_4096", "builtin:showcase", "builtin:metaballs_dense"]
    {
        let (host, device) = (render(scene, Binning::Host), render(scene, Binning::Device));
        let colour = host.0.iter().zip(&device.0).filter(|(a, b)| a != b).count();
        let values = host.1.iter().zip(&device.1).filter(|(a, b)| a != b).count();
        assert_eq!(host.0.len(), device.0.len());
        assert!(colour == 0 && values == 0, "{scene}: {colour} colour bytes and {values} AOV values differ");
    }
}
