//! What registering effects and building their passes can fail with.

/// A registration or a frame plan that cannot work; names the effect, pass or image.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EffectError {
    /// The scene holds data of an effect the renderer was not given (`RendererOptions::effects`).
    #[error(
        "the scene has data of effect `{0}`, which this renderer has not registered (expected it in \
         RendererOptions::effects / RuntimeOptions::effects)"
    )]
    NotRegistered(String),
    /// Two effects registered under one name.
    #[error("two effects are registered as `{0}` (expected unique effect names)")]
    DuplicateEffect(String),
    /// Two passes registered under one name (their timings and labels would be confused).
    #[error("two passes are registered as `{0}` (expected unique pass names across effects)")]
    DuplicatePass(String),
    /// A pass whose `Pass::name()` is not the name its `EffectPass` registers.
    #[error("the pass registered as `{registered}` names itself `{named}` (expected the same name)")]
    PassName {
        /// The `EffectPass::name`.
        registered: &'static str,
        /// What the built pass's `name()` says.
        named: &'static str,
    },
    /// A scene-file table claimed twice (by two effects, or by an effect and hadou's own schema).
    #[error("scene-file table [{table}] of effect `{effect}` is already read by {owner}")]
    TableClaimed {
        /// The table's name.
        table: String,
        /// The effect registered second.
        effect: String,
        /// Who read it first: "hadou's scene format" or an effect's name.
        owner: String,
    },
    /// `update_effect` / `effect` asked for data the loaded scene does not hold.
    #[error("the loaded scene holds no {0} (no effect loaded data of that type)")]
    NoData(&'static str),
    /// A pass declares an image in a way that cannot work: a storage binding outside the GENERAL
    /// layout, or one image with two different uses.
    #[error("pass {pass} declares image {image} wrongly: expected {expected}")]
    Declaration {
        /// The pass.
        pass: &'static str,
        /// The image.
        image: &'static str,
        /// What was expected, and what the pass declared.
        expected: String,
    },
    /// A pass reads an image that no pass of the frame writes before it.
    #[error(
        "pass {pass} reads image {image}, which no earlier pass of this frame writes (it needs {needs})"
    )]
    NotWritten {
        /// The pass.
        pass: &'static str,
        /// The image.
        image: &'static str,
        /// What would write it.
        needs: &'static str,
    },
    /// A pass writes an image's previous frame (`Target::Previous`), which is read-only.
    #[error(
        "pass {pass} writes the previous frame of image {image} (expected Target::Custom for this frame's)"
    )]
    WritesHistory {
        /// The pass.
        pass: &'static str,
        /// The image.
        image: &'static str,
    },
    /// A pass reads an image's previous frame, but no pass of the frame writes this frame's, so
    /// the next frame would have none.
    #[error(
        "pass {pass} reads the previous frame of image {image}, which no pass of this frame writes \
         (it needs {needs})"
    )]
    HistoryNotWritten {
        /// The pass.
        pass: &'static str,
        /// The image.
        image: &'static str,
        /// What would write it.
        needs: &'static str,
    },
}
