# The two commands of README.md. Both install what is missing first (scripts/setup.sh).
CARGO ?= cargo
# Quiet the loader's complaint in headless sessions.
export XDG_RUNTIME_DIR ?= /tmp

.PHONY: setup build demo test check-vulkan lint bless

setup:
	@bash scripts/setup.sh

check-vulkan: setup
	@bash scripts/check-vulkan.sh

build: setup
	$(CARGO) build --release

# Renders the showcase to out/showcase.png (+ its depth AOV), a glTF scene (translucent
# KHR_materials_volume cube) with an energy wave from a TOML overlay to out/gltf_overlay.png,
# prints per-pass timings, and renders examples/custom_effect's height fog (an effect written
# outside the library) to out/custom_effect.png.
demo: build check-vulkan
	mkdir -p out
	./target/release/hadou render assets/scenes/showcase.toml -o out/showcase.png --aov depth=out/showcase_depth.exr
	./target/release/hadou render assets/gltf/overlay.toml -o out/gltf_overlay.png
	./target/release/hadou render assets/scenes/translucency_peel.toml -o out/translucency_peel.png --time 0.5
	./target/release/hadou profile assets/scenes/showcase.toml --size 512x512 --frames 30 --warmup 5
	$(CARGO) run --release --example custom_effect -- out/custom_effect.png

# The whole test suite on lavapipe (or any Vulkan device), validation on in every GPU test.
test: check-vulkan
	$(CARGO) test --workspace

# After an intended visual change: re-make the golden references of tests/golden (then look at
# them and commit). `make test` compares against them bit-exact (tests/golden.rs).
bless: check-vulkan
	$(CARGO) run -- test assets/scenes --refs tests/golden --bless

lint:
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings
