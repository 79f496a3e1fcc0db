//! Screenshots: the last presented frame, written atomically as PNG.

use std::path::{Path, PathBuf};

/// `screenshot-<n>.png` in `dir` with the smallest n ≥ 1 not taken yet.
pub fn next_path(dir: &Path) -> PathBuf {
    (1u32..).map(|n| dir.join(format!("screenshot-{n}.png"))).find(|p| !p.exists()).expect("a free number")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_count_up_past_existing_files() {
        let dir = std::env::temp_dir().join(format!("hadou-shots-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        assert_eq!(next_path(&dir), dir.join("screenshot-1.png"));
        std::fs::write(dir.join("screenshot-1.png"), b"x").unwrap();
        assert_eq!(next_path(&dir), dir.join("screenshot-2.png"));
        std::fs::remove_dir_all(&dir).ok();
    }
}
