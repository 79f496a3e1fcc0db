//! The metaballs pass with its tile lists built on the device (`HADOU_METABALLS_BINNING=device`,
//! the opt-in of passes::metaballs::Binning) renders every byte as the default host binning does:
//! the colour and the HDR, normal and depth AOVs of scenes with one group, 4,096 balls and a
//! showcase world. One test in its own binary: it sets the variable before each renderer is made
//! (the pass reads it when it is built), with no other test running beside it.

mod common;

use hadou::{Aov, FrameRequest};

fn render(scene: &str, device: bool) -> (Vec<u8>, Vec<u32>) {
    if device {
        std::env::set_var("HADOU_METABALLS_BINNING", "device");
    } else {
        std::env::remove_var("HADOU_METABALLS_BINNING");
    }
    let mut rt = common::runtime();
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
    for scene in ["builtin:metaballs", "builtin:metaballs_4096", "builtin:showcase"] {
        let (host, device) = (render(scene, false), render(scene, true));
        let colour = host.0.iter().zip(&device.0).filter(|(a, b)| a != b).count();
        let values = host.1.iter().zip(&device.1).filter(|(a, b)| a != b).count();
        assert_eq!(host.0.len(), device.0.len());
        assert!(colour == 0 && values == 0, "{scene}: {colour} colour bytes and {values} AOV values differ");
    }
    std::env::remove_var("HADOU_METABALLS_BINNING");
}
