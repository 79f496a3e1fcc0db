//! A small glTF 2.0 writer for tests: accessors, meshes, nodes, materials, cameras and lights
//! into JSON, the binary data into one buffer, written as .gltf with an external .bin, as .gltf
//! with a data: URI, or as .glb. Independent of the importer (serde_json and byte pushing only).
#![allow(dead_code)]

use std::path::Path;

use base64::Engine;
use hadou::scene::mesh::Mesh;
use serde_json::{json, Value};

/// Index component widths glTF allows.
#[derive(Clone, Copy, Debug)]
pub enum IndexWidth {
    U8,
    U16,
    U32,
}

#[derive(Default, Clone)]
pub struct Writer {
    pub bin: Vec<u8>,
    pub views: Vec<Value>,
    pub accessors: Vec<Value>,
    pub meshes: Vec<Value>,
    pub nodes: Vec<Value>,
    pub materials: Vec<Value>,
    pub cameras: Vec<Value>,
    pub lights: Vec<Value>,
    pub scene_roots: Vec<usize>,
    pub extensions_used: Vec<String>,
    /// Extra top-level members (animations, skins, textures …), merged last.
    pub extra: serde_json::Map<String, Value>,
}

impl Writer {
    pub fn view(&mut self, bytes: &[u8], target: u32) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.views
            .push(json!({ "buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target }));
        self.views.len() - 1
    }

    /// A VEC3 FLOAT accessor (positions get min/max, which glTF requires for POSITION).
    pub fn vec3(&mut self, v: &[[f32; 3]], min_max: bool) -> usize {
        let bytes: Vec<u8> = v.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
        let view = self.view(&bytes, 34962);
        let mut a = json!({ "bufferView": view, "componentType": 5126, "count": v.len(), "type": "VEC3" });
        if min_max {
            let lo: Vec<f32> = (0..3).map(|k| v.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min)).collect();
            let hi: Vec<f32> =
                (0..3).map(|k| v.iter().map(|p| p[k]).fold(f32::NEG_INFINITY, f32::max)).collect();
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    pub fn indices(&mut self, idx: &[u32], width: IndexWidth) -> usize {
        let (bytes, ty): (Vec<u8>, u32) = match width {
            IndexWidth::U8 => (idx.iter().map(|&i| i as u8).collect(), 5121),
            IndexWidth::U16 => (idx.iter().flat_map(|&i| (i as u16).to_le_bytes()).collect(), 5123),
            IndexWidth::U32 => (idx.iter().flat_map(|&i| i.to_le_bytes()).collect(), 5125),
        };
        let view = self.view(&bytes, 34963);
        self.accessors
            .push(json!({ "bufferView": view, "componentType": ty, "count": idx.len(), "type": "SCALAR" }));
        self.accessors.len() - 1
    }

    /// A triangle primitive of `mesh` (normals written when `normals`), with `material`.
    pub fn primitive(
        &mut self,
        mesh: &Mesh,
        width: IndexWidth,
        normals: bool,
        material: Option<usize>,
    ) -> Value {
        let pos = self.vec3(&mesh.positions, true);
        let mut attributes = json!({ "POSITION": pos });
        if normals {
            attributes["NORMAL"] = json!(self.vec3(&mesh.normals, false));
        }
        let ind = self.indices(&mesh.indices, width);
        let mut p = json!({ "attributes": attributes, "indices": ind, "mode": 4 });
        if let Some(m) = material {
            p["material"] = json!(m);
        }
        p
    }

    pub fn mesh(&mut self, primitives: Vec<Value>) -> usize {
        self.meshes.push(json!({ "primitives": primitives }));
        self.meshes.len() - 1
    }

    pub fn node(&mut self, node: Value) -> usize {
        self.nodes.push(node);
        self.nodes.len() - 1
    }

    pub fn material(&mut self, m: Value) -> usize {
        self.materials.push(m);
        self.materials.len() - 1
    }

    pub fn uses(&mut self, ext: &str) {
        if !self.extensions_used.iter().any(|e| e == ext) {
            self.extensions_used.push(ext.to_owned());
        }
    }

    /// The JSON, with `uri` for the one buffer (None: the GLB's BIN chunk).
    pub fn json(&self, uri: Option<String>) -> Value {
        let mut buffer = json!({ "byteLength": self.bin.len() });
        if let Some(uri) = uri {
            buffer["uri"] = json!(uri);
        }
        let mut root = json!({
            "asset": { "version": "2.0", "generator": "hadou tests/common/gltf_writer.rs" },
            "scene": 0,
            "scenes": [{ "nodes": self.scene_roots }],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [buffer],
        });
        let o = root.as_object_mut().unwrap();
        if !self.materials.is_empty() {
            o.insert("materials".into(), json!(self.materials));
        }
        if !self.cameras.is_empty() {
            o.insert("cameras".into(), json!(self.cameras));
        }
        if !self.lights.is_empty() {
            o.insert("extensions".into(), json!({ "KHR_lights_punctual": { "lights": self.lights } }));
        }
        if !self.extensions_used.is_empty() {
            o.insert("extensionsUsed".into(), json!(self.extensions_used));
        }
        for (k, v) in &self.extra {
            o.insert(k.clone(), v.clone());
        }
        root
    }

    /// `dir/name.gltf` with `dir/name.bin` beside it.
    pub fn write_external(&self, dir: &Path, name: &str) -> std::path::PathBuf {
        let bin = format!("{name}.bin");
        std::fs::write(dir.join(&bin), &self.bin).unwrap();
        let path = dir.join(format!("{name}.gltf"));
        std::fs::write(&path, serde_json::to_vec_pretty(&self.json(Some(bin))).unwrap()).unwrap();
        path
    }

    /// `dir/name.gltf` with the buffer as a base64 data: URI.
    pub fn write_embedded(&self, dir: &Path, name: &str) -> std::path::PathBuf {
        let b64 = base64::engine::general_purpose::STANDARD.encode(&self.bin);
        let uri = format!("data:application/octet-stream;base64,{b64}");
        let path = dir.join(format!("{name}.gltf"));
        std::fs::write(&path, serde_json::to_vec(&self.json(Some(uri))).unwrap()).unwrap();
        path
    }

    /// `dir/name.glb`: header, JSON chunk (space-padded), BIN chunk (zero-padded).
    pub fn write_glb(&self, dir: &Path, name: &str) -> std::path::PathBuf {
        let path = dir.join(format!("{name}.glb"));
        std::fs::write(&path, self.glb()).unwrap();
        path
    }

    pub fn glb(&self) -> Vec<u8> {
        let mut json = serde_json::to_vec(&self.json(None)).unwrap();
        while json.len() % 4 != 0 {
            json.push(b' ');
        }
        let mut bin = self.bin.clone();
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        out
    }
}

/// A fresh, empty folder under the target's temporary folder.
pub fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("hadou-gltf-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The hierarchy scene both test files use: a parent with a translation and a non-uniform scale;
/// under it a child given as a matrix (90° about z, then x + 3) and a mirrored child (scale −1 on
/// x); with `turned`, a third root node rotated 60° about y by a quaternion. All draw one cube
/// mesh (procedural::cube(1), normals written when `normals`) with `material` (a glTF material
/// JSON) if given. Every number is exact in f32, so a TOML scene can state the same values.
pub fn hierarchy(normals: bool, turned: bool, material: Option<Value>) -> Writer {
    let mut w = Writer::default();
    let cube = hadou::scene::procedural::cube(1.0).unwrap();
    let mat = material.map(|m| w.material(m));
    let p = w.primitive(&cube, IndexWidth::U16, normals, mat);
    let m = w.mesh(vec![p]);
    let matrix = [0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 3.0, 0.0, 0.0, 1.0];
    w.node(json!({ "name": "parent", "translation": [0.0, 1.0, -2.0], "scale": [2.0, 0.5, 1.0], "children": [1, 2] }));
    w.node(json!({ "name": "matrix child", "mesh": m, "matrix": matrix }));
    w.node(
        json!({ "name": "mirrored", "mesh": m, "translation": [-3.0, 0.0, 0.0], "scale": [-1.0, 1.0, 1.0] }),
    );
    w.scene_roots = vec![0];
    if turned {
        w.node(json!({ "name": "turned", "mesh": m, "rotation": [0.0, 0.5, 0.0, 0.8660254], "translation": [0.0, 0.0, 2.0] }));
        w.scene_roots.push(3);
    }
    w
}

/// The TOML instances equal to `hierarchy(.., false, ..)`'s nodes: the node's steps, then its
/// parent's, as docs/scene-format.md says glTF nodes become (mesh "cube", material `material`).
pub fn hierarchy_twin_instances(material: &str) -> String {
    let parent = "{ scale = [2, 0.5, 1] }, { translate = [0, 1, -2] }";
    format!(
        "[[mesh]]\nname = \"cube\"\nkind = \"cube\"\n\n\
         [[instance]]\nmesh = \"cube\"\nmaterial = \"{material}\"\n\
         transform = [{{ matrix = [[0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 1, 0], [3, 0, 0, 1]] }}, {parent}]\n\n\
         [[instance]]\nmesh = \"cube\"\nmaterial = \"{material}\"\n\
         transform = [{{ scale = [-1, 1, 1] }}, {{ translate = [-3, 0, 0] }}, {parent}]\n"
    )
}
