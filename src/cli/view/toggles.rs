//! Which passes the viewer runs and which variant each uses. The toggles rewrite the scene the
//! runtime loads (a disabled pass's waves, metaball groups or translucent materials are left out,
//! so the pass is neither built nor run); every change therefore reloads the scene, which rebuilds
//! the passes (shaders come from the compiler's cache, LUTs from the bake cache).

use hadou::scene::model::{MaterialKind, ThicknessMode, WaveMethod};
use hadou::scene::Scene;

/// Steps of the raymarch baseline when the scene file gives none.
pub const DEFAULT_RAYMARCH_STEPS: u32 = 64;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Toggles {
    pub energy_wave: bool,
    pub translucency: bool,
    pub metaballs: bool,
    /// `None`: as in the file; otherwise every translucent material uses this.
    pub thickness: Option<ThicknessMode>,
    /// `None`: as in the file; `Some(true)`: every wave raymarched, `Some(false)`: analytic.
    pub raymarch: Option<bool>,
}

impl Default for Toggles {
    fn default() -> Self {
        Toggles { energy_wave: true, translucency: true, metaballs: true, thickness: None, raymarch: None }
    }
}

impl Toggles {
    /// T: cycles thickness LUT → TSM → peel → LUT, starting from what the file uses.
    pub fn switch_thickness(&mut self, file: &Scene) {
        let now = self.thickness.or_else(|| file_thickness(file)).unwrap_or(ThicknessMode::Lut);
        self.thickness = Some(match now {
            ThicknessMode::Lut => ThicknessMode::Tsm,
            ThicknessMode::Tsm => ThicknessMode::Peel,
            ThicknessMode::Peel | ThicknessMode::Pairs => ThicknessMode::Lut,
        });
    }

    /// R: switches the energy wave between analytic and raymarch, starting from the file.
    pub fn switch_wave_method(&mut self, file: &Scene) {
        let now = self.raymarch.unwrap_or_else(|| {
            file.waves().first().is_some_and(|w| matches!(w.method, WaveMethod::Raymarch { .. }))
        });
        self.raymarch = Some(!now);
    }

    /// The scene to load: `file` with the disabled passes' inputs left out and the switches applied.
    pub fn apply(&self, file: &Scene) -> Scene {
        let mut scene = file.clone();
        let effects = hadou::effect::Effects::builtin();
        let off = [
            ("energy_wave", self.energy_wave),
            ("metaballs", self.metaballs),
            ("translucency", self.translucency),
        ];
        for (name, on) in off {
            if let Some(effect) = effects.get(name).filter(|_| !on) {
                effect.switch_off(&mut scene);
            }
        }
        let file_steps = file.waves().iter().find_map(|w| match w.method {
            WaveMethod::Raymarch { steps, .. } => Some(steps),
            WaveMethod::Analytic => None,
        });
        if let Some(raymarch) = self.raymarch {
            for wave in scene.waves_mut().iter_mut() {
                wave.method = match (raymarch, wave.method) {
                    (false, _) => WaveMethod::Analytic,
                    (true, m @ WaveMethod::Raymarch { .. }) => m,
                    (true, WaveMethod::Analytic) => WaveMethod::Raymarch {
                        steps: file_steps.unwrap_or(DEFAULT_RAYMARCH_STEPS),
                        jitter: false,
                    },
                };
            }
        }
        for material in &mut scene.materials {
            if let (MaterialKind::Translucent { thickness, .. }, Some(mode)) =
                (&mut material.kind, self.thickness)
            {
                *thickness = mode;
            }
        }
        scene
    }

    /// A short summary for the window title, e.g. "wave:analytic trans:lut meta:on".
    pub fn summary(&self, file: &Scene) -> String {
        let scene = self.apply(file);
        let wave = match scene.waves().first().map(|w| w.method) {
            _ if !self.energy_wave => "off".to_string(),
            None => "none".into(),
            Some(WaveMethod::Analytic) => "analytic".into(),
            Some(WaveMethod::Raymarch { steps, .. }) => format!("raymarch {steps}"),
        };
        let trans = match (self.translucency, file_thickness(&scene)) {
            (false, _) => "off",
            (true, None) => "none",
            (true, Some(ThicknessMode::Lut)) => "lut",
            (true, Some(ThicknessMode::Tsm)) => "tsm",
            (true, Some(ThicknessMode::Peel)) => "peel",
            (true, Some(ThicknessMode::Pairs)) => "pairs",
        };
        let meta = match (self.metaballs, file.metaballs().is_empty()) {
            (false, _) => "off",
            (true, true) => "none",
            (true, false) => "on",
        };
        format!("wave:{wave} trans:{trans} meta:{meta}")
    }
}

fn file_thickness(scene: &Scene) -> Option<ThicknessMode> {
    scene.materials.iter().find_map(|m| match m.kind {
        MaterialKind::Translucent { thickness, .. } => Some(thickness),
        MaterialKind::Lambert => None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use hadou::effect::Effects;

    fn plan(scene: &Scene) -> Vec<&'static str> {
        Effects::builtin().plan(scene)
    }

    fn showcase() -> Scene {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes/showcase.toml");
        hadou::scene::load_scene(&path).unwrap()
    }

    #[test]
    fn a_disabled_pass_is_not_planned() {
        let file = showcase();
        let all = plan(&Toggles::default().apply(&file));
        for kind in ["energy_wave", "translucency", "light_id", "metaballs"] {
            assert!(all.contains(&kind), "the showcase uses {kind}");
        }
        let t = Toggles { energy_wave: false, ..Default::default() };
        assert!(!plan(&t.apply(&file)).contains(&"energy_wave"));
        let t = Toggles { translucency: false, ..Default::default() };
        let p = plan(&t.apply(&file));
        assert!(!p.contains(&"translucency") && !p.contains(&"light_id"));
        let t = Toggles { metaballs: false, ..Default::default() };
        assert!(!plan(&t.apply(&file)).contains(&"metaballs"));
        assert_eq!(Toggles::default().apply(&file).instances, file.instances, "instances are kept");
    }

    #[test]
    fn switches_cycle_from_the_file_and_back() {
        let file = showcase();
        let mut t = Toggles::default();
        t.switch_thickness(&file);
        t.switch_wave_method(&file);
        let s = t.apply(&file);
        assert!(s
            .materials
            .iter()
            .any(|m| matches!(m.kind, MaterialKind::Translucent { thickness: ThicknessMode::Tsm, .. })));
        assert_eq!(
            s.waves()[0].method,
            WaveMethod::Raymarch { steps: DEFAULT_RAYMARCH_STEPS, jitter: false }
        );
        assert_eq!(t.summary(&file), format!("wave:raymarch {DEFAULT_RAYMARCH_STEPS} trans:tsm meta:on"));
        t.switch_thickness(&file);
        t.switch_wave_method(&file);
        let s = t.apply(&file);
        assert_eq!(s.waves()[0].method, WaveMethod::Analytic);
        assert_eq!(t.summary(&file), "wave:analytic trans:peel meta:on");
        // LUT → TSM → peel → LUT.
        t.switch_thickness(&file);
        assert_eq!(t.apply(&file).materials, file.materials);
    }
}
