//! One source of truth per struct shared with GLSL: a Rust `#[repr(C)]` struct declares its GLSL
//! twin's name and members (`gpu_layout!`), and `check` compares every member — name, offset and
//! GLSL type — with the struct as a shader's SPIR-V lays it out (`reflect::structs`). A size check
//! alone cannot see two `vec4` members swapped; this can. The comparison runs in the tests
//! (hadou's `passes::shader_structs`: every shader with every struct it shares), so the
//! declarations' impls compile only in the tests of the crate that declares them.

/// Declares a `#[repr(C)]` struct's GLSL twin: `gpu_layout!(GpuLight as "Light" { direction,
/// radiance });` lists every field in order (a field left out fails `Layout::check_complete`).
#[macro_export]
macro_rules! gpu_layout {
    ($ty:ident as $glsl:literal { $($field:ident),+ $(,)? }) => {
        #[cfg(test)]
        impl $crate::layout::GpuLayout for $ty {
            const GLSL_NAME: &'static str = $glsl;
            fn layout() -> $crate::layout::Layout {
                $crate::layout::Layout {
                    rust_name: stringify!($ty),
                    glsl_name: $glsl,
                    size: std::mem::size_of::<$ty>(),
                    members: vec![$($crate::layout::Member {
                        name: stringify!($field),
                        offset: std::mem::offset_of!($ty, $field),
                        size: $crate::layout::field_size(|s: &$ty| &s.$field),
                        glsl: $crate::layout::field_glsl(|s: &$ty| &s.$field),
                    }),+],
                }
            }
        }
    };
}
pub use crate::gpu_layout;

pub use check::*;

mod check {
    use crate::reflect::ReflectedStruct;

    /// A member of a Rust struct shared with GLSL.
    #[derive(Clone, Debug, PartialEq, Eq)]
    pub struct Member {
        /// The field's name, which is the GLSL member's name.
        pub name: &'static str,
        /// Byte offset (`offset_of!`).
        pub offset: usize,
        /// Bytes of the field.
        pub size: usize,
        /// The GLSL type the field's Rust type stands for (`[f32; 4]` → `vec4`).
        pub glsl: String,
    }

    /// A Rust struct shared with GLSL, as `gpu_layout!` describes it.
    #[derive(Clone, Debug, PartialEq, Eq)]
    pub struct Layout {
        /// The Rust type's name.
        pub rust_name: &'static str,
        /// The GLSL struct or block type's name.
        pub glsl_name: &'static str,
        /// `size_of` the Rust type.
        pub size: usize,
        /// In declaration order.
        pub members: Vec<Member>,
    }

    /// A struct shared with GLSL; implemented by `gpu_layout!`.
    pub trait GpuLayout {
        /// The GLSL twin's type name.
        const GLSL_NAME: &'static str;
        /// Its members as Rust lays them out.
        fn layout() -> Layout;
    }

    /// The GLSL type a Rust field type stands for.
    pub trait GlslType {
        /// As GLSL spells it.
        fn glsl() -> String;
    }

    macro_rules! glsl_types {
        ($($rust:ty => $glsl:literal),* $(,)?) => {
            $(impl GlslType for $rust {
                fn glsl() -> String {
                    $glsl.to_string()
                }
            })*
        };
    }

    glsl_types! {
        f32 => "float", u32 => "uint", i32 => "int",
        [f32; 2] => "vec2", [f32; 3] => "vec3", [f32; 4] => "vec4",
        [u32; 2] => "uvec2", [u32; 3] => "uvec3", [u32; 4] => "uvec4",
        [i32; 2] => "ivec2", [i32; 3] => "ivec3", [i32; 4] => "ivec4",
        [[f32; 4]; 4] => "mat4", [[f32; 4]; 3] => "mat3x4",
    }

    /// An array of a shared struct is an array of its GLSL twin.
    impl<T: GpuLayout, const N: usize> GlslType for [T; N] {
        fn glsl() -> String {
            format!("{}[{N}]", T::GLSL_NAME)
        }
    }

    /// A shared struct inside another is its GLSL twin.
    impl<T: GpuLayout> GlslType for T {
        fn glsl() -> String {
            T::GLSL_NAME.to_string()
        }
    }

    /// The GLSL type of the field `field` selects (for `gpu_layout!`; the closure is never called).
    pub fn field_glsl<S, T: GlslType>(_field: fn(&S) -> &T) -> String {
        T::glsl()
    }

    /// The size of the field `field` selects (for `gpu_layout!`; the closure is never called).
    pub fn field_size<S, T>(_field: fn(&S) -> &T) -> usize {
        std::mem::size_of::<T>()
    }

    impl Layout {
        /// The listed fields cover the struct with no gap and no overlap (a `Pod` struct has no
        /// padding, so a field left out of `gpu_layout!` leaves a gap).
        pub fn check_complete(&self) -> Result<(), String> {
            let mut end = 0;
            for m in &self.members {
                if m.offset != end {
                    return Err(format!(
                        "{}: bytes {end}..{} are not in its gpu_layout! (a field left out or out of order)",
                        self.rust_name, m.offset
                    ));
                }
                end = m.offset + m.size;
            }
            if end != self.size {
                return Err(format!(
                    "{}: bytes {end}..{} are not in its gpu_layout!",
                    self.rust_name, self.size
                ));
            }
            Ok(())
        }

        /// Compares every member with a shader's struct of the same name: count, names, offsets and
        /// GLSL types must agree.
        pub fn check(&self, shader: &str, reflected: &ReflectedStruct) -> Result<(), String> {
            self.check_complete()?;
            let theirs = &reflected.members;
            if theirs.len() != self.members.len() {
                return Err(format!(
                    "{shader}: {} has {} members, its Rust twin {} has {}",
                    self.glsl_name,
                    theirs.len(),
                    self.rust_name,
                    self.members.len()
                ));
            }
            for (i, (ours, theirs)) in self.members.iter().zip(theirs).enumerate() {
                if ours.name != theirs.name
                    || ours.offset != theirs.offset as usize
                    || ours.glsl != theirs.glsl
                {
                    return Err(format!(
                        "{shader}: {} member {i} is `{} {}` at byte {}, its Rust twin {} has `{} {}` at byte {}",
                        self.glsl_name,
                        theirs.glsl,
                        theirs.name,
                        theirs.offset,
                        self.rust_name,
                        ours.glsl,
                        ours.name,
                        ours.offset
                    ));
                }
            }
            Ok(())
        }

        /// Checks this struct against every struct of its GLSL name in a shader's SPIR-V (one per
        /// layout it is used under); an error when the shader has none.
        pub fn check_in(&self, shader: &str, structs: &[ReflectedStruct]) -> Result<(), String> {
            let mut found = 0;
            for s in structs.iter().filter(|s| s.name == self.glsl_name) {
                self.check(shader, s)?;
                found += 1;
            }
            if found == 0 {
                return Err(format!(
                    "{shader} has no struct {} (the twin of {})",
                    self.glsl_name, self.rust_name
                ));
            }
            Ok(())
        }
    }
}
