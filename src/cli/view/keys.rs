//! The viewer's keys: one table gives the actions, `--help` and the README's list.

use std::collections::HashSet;

use winit::keyboard::KeyCode;

use super::camera_control::Motion;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    Quit,
    TogglePause,
    StepFrame,
    ToggleEnergyWave,
    ToggleTranslucency,
    ToggleMetaballs,
    SwitchThickness,
    SwitchWaveMethod,
    SwitchCameraMode,
    ResetCamera,
    Screenshot,
}

/// (key, script name, action, what it does). Script names are what `--script key=NAME` takes.
pub const KEYS: &[(KeyCode, &str, Action, &str)] = &[
    (KeyCode::Space, "space", Action::TogglePause, "pause / resume time"),
    (KeyCode::Period, "period", Action::StepFrame, "step time by one frame (1/60 s) and pause"),
    (KeyCode::Digit1, "1", Action::ToggleEnergyWave, "energy wave pass on / off"),
    (KeyCode::Digit2, "2", Action::ToggleTranslucency, "translucency pass on / off"),
    (KeyCode::Digit3, "3", Action::ToggleMetaballs, "metaballs pass on / off"),
    (KeyCode::KeyT, "t", Action::SwitchThickness, "translucent thickness: LUT -> TSM -> peel"),
    (KeyCode::KeyR, "r", Action::SwitchWaveMethod, "energy wave: analytic <-> raymarch"),
    (KeyCode::KeyC, "c", Action::SwitchCameraMode, "camera: orbit <-> fly"),
    (KeyCode::Home, "home", Action::ResetCamera, "camera back to the scene's"),
    (KeyCode::F12, "f12", Action::Screenshot, "screenshot to screenshot-<n>.png"),
    (KeyCode::KeyP, "p", Action::Screenshot, "screenshot (same as F12)"),
    (KeyCode::Escape, "escape", Action::Quit, "quit"),
];

/// Held keys that move the camera (both modes; fly moves the eye, orbit pans the target).
const MOVE_KEYS: &[(KeyCode, Motion)] = &[
    (KeyCode::KeyW, Motion { right: 0.0, up: 0.0, forward: 1.0 }),
    (KeyCode::KeyS, Motion { right: 0.0, up: 0.0, forward: -1.0 }),
    (KeyCode::KeyD, Motion { right: 1.0, up: 0.0, forward: 0.0 }),
    (KeyCode::KeyA, Motion { right: -1.0, up: 0.0, forward: 0.0 }),
    (KeyCode::KeyE, Motion { right: 0.0, up: 1.0, forward: 0.0 }),
    (KeyCode::KeyQ, Motion { right: 0.0, up: -1.0, forward: 0.0 }),
];

pub fn action(key: KeyCode) -> Option<Action> {
    KEYS.iter().find(|k| k.0 == key).map(|k| k.2)
}

pub fn action_by_name(name: &str) -> Option<Action> {
    KEYS.iter().find(|k| k.1.eq_ignore_ascii_case(name)).map(|k| k.2)
}

pub fn is_move_key(key: KeyCode) -> bool {
    MOVE_KEYS.iter().any(|m| m.0 == key)
}

/// The motion the held keys ask for (opposite keys cancel).
pub fn motion(held: &HashSet<KeyCode>) -> Motion {
    let mut m = Motion::default();
    for (key, dir) in MOVE_KEYS {
        if held.contains(key) {
            m.right += dir.right;
            m.up += dir.up;
            m.forward += dir.forward;
        }
    }
    m
}

/// The key list for `hadou view --help`.
pub const HELP: &str = "\
Keys:
  mouse drag (left)   orbit: turn about the target; fly: look around
  mouse wheel         orbit: zoom; fly: move forward / back
  W A S D / Q E       move forward, left, back, right / down, up
  C                   camera: orbit <-> fly
  Home                camera back to the scene's
  Space               pause / resume time
  .                   step time by one frame (1/60 s) and pause
  1 / 2 / 3           energy wave / translucency / metaballs pass on / off
  T                   translucent thickness: LUT -> TSM -> peel
  R                   energy wave: analytic <-> raymarch
  F12 or P            screenshot to screenshot-<n>.png (current directory)
  Esc                 quit
Per-pass GPU times are in the window title (averaged, updated twice a second).";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_action_has_a_key_and_a_script_name() {
        for key in KEYS {
            assert_eq!(action(key.0), Some(key.2));
            assert_eq!(action_by_name(key.1), Some(key.2), "{}", key.1);
        }
        assert_eq!(action(KeyCode::KeyW), None, "movement keys are held, not actions");
    }

    #[test]
    fn opposite_keys_cancel() {
        let held: HashSet<_> = [KeyCode::KeyW, KeyCode::KeyS, KeyCode::KeyD].into_iter().collect();
        assert_eq!(motion(&held), Motion { right: 1.0, up: 0.0, forward: 0.0 });
    }
}
