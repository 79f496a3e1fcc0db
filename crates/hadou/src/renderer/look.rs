//! A frame's exposure, ambient light and background, set at run time as `[render]` sets them in a
//! file (issue 23 item 4): the next recorded frame uses them. Checked by the file's rules; a
//! refused call changes nothing.

use glam::DVec3;

use super::game_math::GameVector;
use super::Renderer;
use crate::effects::tonemap::ev100_exposure;
use crate::scene::file::MAX_HDR;
use crate::scene::ExposureMode;
use crate::Error;

/// How frames are exposed: `[render] exposure` / `exposure_ev100` at run time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Exposure {
    /// The linear factor the HDR colour is multiplied by before the tonemap curve (a normal,
    /// finite f32 > 0).
    Linear(f64),
    /// Photographic exposure value at ISO 100, in [-120, 120]: factor 1 / (1.2 · 2^EV100).
    Ev100(f64),
    /// Measured from each frame's luminance, adapting over time.
    Auto,
}

fn refused(what: String, expected: &str) -> Error {
    Error::InvalidUpdate { what, expected: expected.into() }
}

/// An ambient or background colour as `[render]` takes it.
fn check_colour(what: &str, c: DVec3) -> Result<(), Error> {
    if c.is_finite() && c.min_element() >= 0.0 && c.max_element() <= MAX_HDR {
        return Ok(());
    }
    Err(refused(format!("{what} {c}"), "3 numbers in [0, 65504] (the HDR target is 16-bit float)"))
}

impl Renderer {
    /// Sets how the next frames are exposed.
    pub fn set_exposure(&mut self, exposure: Exposure) -> Result<(), Error> {
        let (factor, mode) = match exposure {
            Exposure::Linear(e)
                if e.is_finite() && e >= f64::from(f32::MIN_POSITIVE) && e <= f64::from(f32::MAX) =>
            {
                (e, ExposureMode::Linear)
            }
            Exposure::Linear(e) => {
                return Err(refused(
                    format!("exposure {e}"),
                    "a finite number >= 1.1754944e-38, within f32's range",
                ))
            }
            Exposure::Ev100(ev) if (-120.0..=120.0).contains(&ev) => {
                (ev100_exposure(ev), ExposureMode::Ev100(ev))
            }
            Exposure::Ev100(ev) => {
                return Err(refused(format!("exposure_ev100 {ev}"), "a number in [-120, 120]"))
            }
            Exposure::Auto => (1.0, ExposureMode::Auto),
        };
        let render = &mut self.loaded.as_mut().ok_or(Error::NoScene)?.scene.render;
        (render.exposure, render.exposure_mode) = (factor, mode);
        Ok(())
    }

    /// Sets the ambient light added to every lit surface (times its albedo) from the next frame.
    pub fn set_ambient(&mut self, ambient: impl GameVector) -> Result<(), Error> {
        let ambient = ambient.to_dvec3();
        check_colour("ambient", ambient)?;
        self.loaded.as_mut().ok_or(Error::NoScene)?.scene.render.ambient = ambient;
        Ok(())
    }

    /// Sets the HDR colour where no surface is hit from the next frame (a game's own frame is
    /// composited with a transparent background whatever this says).
    pub fn set_background(&mut self, background: impl GameVector) -> Result<(), Error> {
        let background = background.to_dvec3();
        check_colour("background", background)?;
        self.loaded.as_mut().ok_or(Error::NoScene)?.scene.render.background = background;
        Ok(())
    }
}
