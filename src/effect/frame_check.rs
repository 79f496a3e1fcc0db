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

/// Refuses an image binding of `pass` that its `images()` does not declare, or declares for
/// another kind of access (a storage image is used in the GENERAL layout).
pub(crate) fn check_bindings(
    pass: &dyn Pass,
    uses: &[ImageUse],
    bindings: &[Binding],
) -> Result<(), EffectError> {
    for b in bindings {
        let (target, binding) = match *b {
            Binding::Image(t) => (t, "a storage image"),
            Binding::SampledImage(t, _) => (t, "a sampled image"),
            _ => continue,
        };
        let declared: Vec<&ImageUse> = uses.iter().filter(|u| u.target == target).collect();
        let fits = |u: &&ImageUse| match b {
            Binding::Image(_) => u.access.layout == vk::ImageLayout::GENERAL,
            _ => true,
        };
        if !declared.iter().any(fits) {
            let declared = match declared.first() {
                None => "images() does not declare it".to_string(),
                Some(u) => format!("images() declares it in layout {:?}", u.access.layout),
            };
            return Err(EffectError::Undeclared {
                pass: pass.name(),
                image: target.name(),
                binding,
                declared,
            });
        }
    }
    Ok(())
}
