//! The checks the runner makes on a frame's passes once they are prepared: every image a pass
//! binds is one it declared, bound the way its declared access allows, and every image a pass
//! only reads is written by an earlier pass of the frame (or is the game's own). A frame that
//! fails is refused with an error naming the pass and the image, before any command is recorded.

use super::EffectError;
use crate::gpu::vk;
use crate::passes::{Binding, ImageUse, Pass};
use crate::targets::Target;

/// Refuses a pass reading an image no earlier pass of the frame writes; `passes` are the frame's
/// passes in order, each with the images it declared. An image's previous frame
/// (`Target::Previous`) is read-only, and read only where some pass of the frame (before or after
/// the reader) writes this frame's image, which becomes the next frame's previous one.
pub(crate) fn check_reads<'a>(
    passes: impl Iterator<Item = (&'static str, &'a [ImageUse])> + Clone,
) -> Result<(), EffectError> {
    let written_anywhere: Vec<Target> = passes
        .clone()
        .flat_map(|(_, uses)| uses.iter().filter(|u| u.access.writes()).map(|u| u.target))
        .collect();
    let mut written: Vec<Target> = Vec::new();
    for (pass, uses) in passes {
        for u in uses {
            if let Some(current) = u.target.current() {
                if u.access.writes() {
                    return Err(EffectError::WritesHistory { pass, image: u.target.name() });
                }
                if !written_anywhere.contains(&current) {
                    let (image, needs) = (u.target.name(), u.target.needs());
                    return Err(EffectError::HistoryNotWritten { pass, image, needs });
                }
                continue;
            }
            if !u.access.writes() && !u.target.is_external() && !written.contains(&u.target) {
                return Err(EffectError::NotWritten {
                    pass,
                    image: u.target.name(),
                    needs: u.target.needs(),
                });
            }
        }
        written.extend(uses.iter().filter(|u| u.access.writes()).map(|u| u.target));
    }
    Ok(())
}

/// The images `pass` touches this frame: those its bindings declare and those `images()` adds
/// (attachments, copies). An image may appear more than once only with the same use (a pass
/// binding one image to two of its pipelines); a storage image is bound in the GENERAL layout.
pub(crate) fn declared_images(
    pass: &dyn Pass,
    images: Vec<ImageUse>,
    bindings: &[Binding],
) -> Result<Vec<ImageUse>, EffectError> {
    let mut uses: Vec<ImageUse> = Vec::with_capacity(images.len() + bindings.len());
    let declared = bindings
        .iter()
        .filter_map(|b| b.image_use().map(|u| (u, Some(b))))
        .chain(images.into_iter().map(|u| (u, None)));
    for (u, binding) in declared {
        if let Some(Binding::Image(_)) = binding {
            if u.access.layout != vk::ImageLayout::GENERAL {
                return Err(EffectError::Declaration {
                    pass: pass.name(),
                    image: u.target.name(),
                    expected: format!(
                        "a storage image binding in the GENERAL layout (it declares {:?})",
                        u.access.layout
                    ),
                });
            }
        }
        match uses.iter().find(|d| d.target == u.target) {
            Some(d) if *d == u => {}
            Some(d) => {
                return Err(EffectError::Declaration {
                    pass: pass.name(),
                    image: u.target.name(),
                    expected: format!(
                        "one use per image in a pass (it is declared with {:?} and with {:?})",
                        d.access, u.access
                    ),
                });
            }
            None => uses.push(u),
        }
    }
    Ok(uses)
}
