//! Triangle meshes from OBJ (tobj) and glTF 2.0 (gltf), validated and repaired.
//!
//! Input rules (each violation is an error naming the file, or a documented repair):
//! - non-finite positions or out-of-range indices: error;
//! - zero-area triangles: dropped, with a warning (a mesh left with none is an error);
//! - missing or non-finite normals: recomputed, area-weighted, with a warning.

use super::gltf_import::GltfScene;
use super::{Material, Result, SceneError};
use engine_io::excerpt;
use glam::Vec3;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub indices: Vec<u32>,
    /// Per-vertex material offsets (empty: 0 everywhere): vertex v of an instance is shaded with material
    /// `instance.material + material_offsets[v]`, so one mesh can carry spatially varying parameters (a
    /// material map, `engine::scene::material_map`). Per-pixel shading takes the offset of a triangle's first
    /// vertex (flat, like the material index); per-vertex shading takes each vertex's own.
    pub material_offsets: Vec<u32>,
}

impl Mesh {
    /// Validate and repair (see the module doc). `origin` names the source in messages; `name` is kept as
    /// [`engine_io::excerpt`] writes it (control characters escaped, at most 80 characters).
    pub fn new(
        origin: &Path,
        name: &str,
        positions: Vec<Vec3>,
        normals: Option<Vec<Vec3>>,
        indices: Vec<u32>,
    ) -> Result<Self> {
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(SceneError::invalid(
                origin,
                format!("mesh '{name}': vertex {i} has a non-finite position {:?}", positions[i]),
            ));
        }
        if !indices.len().is_multiple_of(3) {
            return Err(SceneError::invalid(
                origin,
                format!("mesh '{name}': index count {} is not a multiple of 3", indices.len()),
            ));
        }
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(SceneError::invalid(
                origin,
                format!("mesh '{name}': index {bad} out of range ({} vertices)", positions.len()),
            ));
        }
        let mut kept = Vec::with_capacity(indices.len());
        let mut dropped = 0;
        for t in indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| positions[i as usize]);
            let area2 = (b - a).cross(c - a).length();
            let scale = (b - a).length_squared().max((c - a).length_squared()).max(f32::MIN_POSITIVE);
            if area2 <= 1e-12 * scale {
                dropped += 1;
            } else {
                kept.extend_from_slice(t);
            }
        }
        if dropped > 0 {
            log::warn!("{}: mesh '{name}': dropped {dropped} zero-area triangle(s)", origin.display());
        }
        if kept.is_empty() {
            return Err(SceneError::invalid(origin, format!("mesh '{name}' has no triangles with nonzero area")));
        }
        let normals = match normals {
            Some(n) if n.len() == positions.len() && n.iter().all(|v| v.is_finite() && v.length_squared() > 0.0) => {
                n.into_iter().map(|v| v.normalize()).collect()
            }
            Some(_) => {
                log::warn!("{}: mesh '{name}': invalid normals, recomputed", origin.display());
                compute_normals(&positions, &kept)
            }
            None => compute_normals(&positions, &kept),
        };
        // The name comes from the file (an OBJ's file stem and material names, a glTF mesh's name) and is printed
        // in progress lines and messages: escaped and cut short like any quoted input.
        Ok(Self { name: excerpt(name), positions, normals, indices: kept, material_offsets: Vec::new() })
    }

    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// The material offset of vertex `v` ([`Mesh::material_offsets`]).
    pub fn material_offset(&self, v: usize) -> u32 {
        self.material_offsets.get(v).copied().unwrap_or(0)
    }
}

/// Area-weighted vertex normals (unit length; +Y for vertices of no triangle).
pub fn compute_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| i as usize);
        let f = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        n[a] += f;
        n[b] += f;
        n[c] += f;
    }
    n.into_iter().map(|v| v.normalize_or(Vec3::Y)).collect()
}

/// Relative (negative) OBJ indices that reach before the first element, refused before `tobj` sees them: it
/// adds them to the count unchecked, and `f 1//-11` with one normal overflowed its index arithmetic (a panic
/// with overflow checks; a wrapped index without). Found by the fuzzer (tools/fuzz/corpus/obj).
fn check_relative_indices(text: &str) -> std::result::Result<(), String> {
    let (mut v, mut vt, mut vn) = (0i64, 0i64, 0i64);
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => v += 1,
            Some("vt") => vt += 1,
            Some("vn") => vn += 1,
            Some("f" | "l" | "p") => {
                for w in words {
                    for (k, part) in w.split('/').enumerate() {
                        let count = [v, vt, vn].get(k).copied().unwrap_or(0);
                        match part.parse::<i64>() {
                            Ok(i) if i < 0 && i.checked_neg().is_none_or(|m| m > count) => {
                                return Err(format!(
                                    "line {}: relative index {i} reaches before the first of {count} elements",
                                    n + 1
                                ));
                            }
                            _ => {}
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// The `.mtl` statements whose values `tobj` parses as colours (three numbers).
const MTL_COLOURS: &[&str] = &["Ka", "Kd", "Ks", "Ke"];
/// The `.mtl` statements whose value `tobj` parses as one number.
const MTL_SCALARS: &[&str] = &["Ns", "Ni", "d"];

/// A `.mtl` file's text checked line by line before `tobj` parses it, as `tobj` would read it: its colour parser
/// panics on fewer than three numbers (a bare `Kd` was reported as a broken OBJ), and it takes `nan` and `inf`
/// (`Kd nan` rendered as black). Returns the text to parse: a colour of one number `r` is the spec's `r r r`.
/// An error is `(line, what is wrong)`. Material values must be finite ([`super::check_material_values`]).
fn check_mtl(text: &str) -> std::result::Result<String, (usize, String)> {
    let mut out = String::with_capacity(text.len());
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let keyword = words.next().unwrap_or("");
        let args: Vec<&str> = words.take_while(|w| !w.starts_with('#')).collect();
        let number = |w: &str| -> std::result::Result<f32, String> {
            let x: f32 = w.parse().map_err(|_| format!("`{keyword}`: '{}' is not a number", excerpt(w)))?;
            super::check_material_values(&format!("`{keyword}` value '{}'", excerpt(w)), &[x])?;
            Ok(x)
        };
        let err = |m: String| (n + 1, m);
        if MTL_COLOURS.contains(&keyword) {
            let values = args.iter().map(|w| number(w)).collect::<std::result::Result<Vec<f32>, String>>();
            match (values.map_err(err)?.as_slice(), args.len()) {
                (&[r], 1) => {
                    out.push_str(&format!("{keyword} {r} {r} {r}\n"));
                    continue;
                }
                // More than three: tobj reads the first three (as before).
                (_, k) if k >= 3 => {}
                (_, k) => return Err(err(format!("`{keyword}` needs three numbers (r g b) or one; it has {k}"))),
            }
        } else if MTL_SCALARS.contains(&keyword) {
            match args.as_slice() {
                [w] => {
                    number(w).map_err(err)?;
                }
                _ => return Err(err(format!("`{keyword}` needs one number; it has {}", args.len()))),
            }
        } else if keyword == "illum" && !matches!(args.as_slice(), [w] if w.parse::<u8>().is_ok()) {
            return Err(err("`illum` needs one illumination model number (0 to 10)".into()));
        }
        out.push_str(line);
        out.push('\n');
    }
    Ok(out)
}

/// The `.mtl` statements that name a texture file (MTL spec: `map_*`, `bump`, `disp`, `decal`, `refl`).
fn is_texture_statement(keyword: &str) -> bool {
    keyword.starts_with("map_") || matches!(keyword, "bump" | "disp" | "decal" | "refl")
}

/// Every texture map a `.mtl` names must be inside the OBJ's folder, resolved against the `.mtl`'s own folder
/// ([`engine_io::ModelFolder`]). The renderer reads no textures; the names are checked all the same, so that no
/// model file can name a file outside its folder. A statement's value may start with options (`-s 1 1 1
/// wood.png`): the whole value and its last word are both checked. An error is `(line, what is wrong)`.
fn check_mtl_textures(
    text: &str,
    mtl: &Path,
    folder: &engine_io::ModelFolder,
) -> std::result::Result<(), (usize, String)> {
    for (n, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        let (keyword, value) = line.split_once(char::is_whitespace).unwrap_or((line, ""));
        let value = value.trim();
        if !is_texture_statement(keyword) || value.is_empty() {
            continue;
        }
        let last = value.split_whitespace().last().unwrap_or(value);
        for name in [value, last] {
            folder
                .resolve(mtl.parent(), name)
                .map_err(|m| (n + 1, format!("`{keyword}` texture {} {m}", engine_io::quote(name))))?;
        }
    }
    Ok(())
}

/// One `.mtl` file, read through `engine_io` and checked ([`check_mtl`], [`check_mtl_textures`]). A file that
/// does not exist is the documented warning (the meshes get the default grey): `Ok(Err(OpenFileFailed))`, as
/// `tobj` reports it.
fn load_mtl(mtl: &Path, obj: &Path, folder: &engine_io::ModelFolder) -> Result<tobj::MTLLoadResult> {
    let text = match engine_io::read_to_string(mtl, engine_io::Limit::MATERIAL_LIBRARY) {
        Ok(t) => t,
        Err(engine_io::InputError::NotFound { .. }) => {
            log::warn!("{}: material library {} not found; default grey", obj.display(), mtl.display());
            return Ok(Err(tobj::LoadError::OpenFileFailed));
        }
        Err(e) => {
            return Err(SceneError::invalid(mtl, format!("{} (material library of {})", e.message(), obj.display())))
        }
    };
    let bad = |m: String| SceneError::invalid(mtl, format!("{m} (material library of {})", obj.display()));
    let checked = check_mtl(&text).map_err(|(line, m)| bad(format!("line {line}: {m}")))?;
    check_mtl_textures(&text, mtl, folder).map_err(|(line, m)| bad(format!("line {line}: {m}")))?;
    match engine_io::catch_quiet(|| tobj::load_mtl_buf(&mut checked.as_bytes())) {
        Ok(Ok(m)) => Ok(Ok(m)),
        Ok(Err(e)) => Err(bad(format!("not a valid material library: {e}"))),
        Err(_) => Err(bad("not a valid material library (the parser panicked on it)".into())),
    }
}

/// Parse an OBJ file read through `engine_io`: relative indices checked first, its `mtllib` files (with
/// `materials`) resolved inside the OBJ's folder ([`engine_io::ModelFolder`]: no traversal, absolute path,
/// `file:` URI or symbolic link out) and read through [`load_mtl`] (tobj's own loader would open any file,
/// `/dev/zero` included), and a panic inside the `tobj` parser contained quietly as an error naming the file.
type ObjParse = (Vec<tobj::Model>, std::result::Result<Vec<tobj::Material>, tobj::LoadError>);
fn parse_obj(path: &Path, materials: bool) -> Result<ObjParse> {
    let bytes = engine_io::read(path, engine_io::Limit::MESH)?;
    check_relative_indices(&String::from_utf8_lossy(&bytes))
        .map_err(|m| SceneError::invalid(path, format!("not a valid OBJ file: {m}")))?;
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    let mtl_error = std::cell::RefCell::new(None);
    // Without materials no .mtl is read: the folder is needed only with them.
    let folder = materials.then(|| engine_io::ModelFolder::of(path)).transpose()?;
    let loader = |name: &Path| -> tobj::MTLLoadResult {
        let Some(folder) = folder.as_ref().filter(|_| mtl_error.borrow().is_none()) else {
            return Err(tobj::LoadError::OpenFileFailed);
        };
        let name = name.to_string_lossy();
        let resolved = folder
            .resolve(None, &name)
            .map_err(|m| SceneError::invalid(path, format!("mtllib {} {m}", engine_io::quote(&name))))
            .and_then(|full| load_mtl(&full, path, folder));
        match resolved {
            Ok(m) => m,
            Err(e) => {
                *mtl_error.borrow_mut() = Some(e);
                Err(tobj::LoadError::ReadError)
            }
        }
    };
    let parsed = engine_io::catch_quiet(|| tobj::load_obj_buf(&mut &bytes[..], &opts, loader));
    if let Some(e) = mtl_error.take() {
        return Err(e);
    }
    match parsed {
        Ok(Ok(m)) => Ok(m),
        Ok(Err(e)) => Err(SceneError::invalid(path, format!("not a valid OBJ file: {e}"))),
        Err(_) => Err(SceneError::invalid(path, "not a valid OBJ file (the OBJ parser panicked on it)")),
    }
}

/// Load every object of an OBJ file as one mesh (its `.mtl` is not read). Malformed files are errors naming the
/// file ([`parse_obj`]).
pub fn load_obj(path: &Path) -> Result<Mesh> {
    let (models, _materials) = parse_obj(path, false)?;
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut indices = Vec::new();
    let mut all_normals = true;
    for m in &models {
        let base = positions.len() as u32;
        let p = &m.mesh.positions;
        positions.extend(p.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        if m.mesh.normals.len() == p.len() {
            normals.extend(m.mesh.normals.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        } else {
            all_normals = false;
        }
        let nverts = (p.len() / 3) as u32;
        for &i in &m.mesh.indices {
            if i >= nverts {
                return Err(SceneError::invalid(
                    path,
                    format!("object '{}': index {i} out of range ({nverts} vertices)", m.name),
                ));
            }
            indices.push(base + i);
        }
    }
    if positions.is_empty() {
        return Err(SceneError::invalid(path, "no vertices (not an OBJ mesh?)"));
    }
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    Mesh::new(path, &name, positions, all_normals.then_some(normals), indices)
}

/// Load an OBJ file with its `.mtl` materials: one mesh per material (objects sharing a material are merged;
/// faces with none form one more mesh), each with its [`Material`]: `Kd` → diffuse ρ_d, `Ks` → specular k_s,
/// `Ns` → the Blinn-Phong exponent s (as written: OBJ's Phong exponent is used as ours; clamped to [1, 1e5]).
/// Colours are clamped to [0, 1]; a non-finite value (`Kd nan`, `Ks inf`) is an error naming the `.mtl` and its
/// line ([`check_mtl`]). A missing `.mtl` is a warning (the meshes get the default grey); one that cannot be read
/// (not a regular file, over its size limit) or does not parse is an error naming it.
pub fn load_obj_with_materials(path: &Path) -> Result<(Vec<Mesh>, Vec<Material>)> {
    let (models, materials) = parse_obj(path, true)?;
    obj_meshes_by_material(path, models, materials)
}

/// One `.mtl` material on our model (its values finite: [`check_mtl`]).
pub fn material_from_mtl(m: &tobj::Material) -> Material {
    let unit = |c: [f32; 3]| Vec3::from(c).clamp(Vec3::ZERO, Vec3::ONE);
    let mut out = Material::diffuse(m.diffuse.map(unit).unwrap_or(Vec3::splat(0.8)));
    if let Some(ks) = m.specular {
        out.specular = unit(ks);
    }
    if let Some(ns) = m.shininess.filter(|s| s.is_finite()) {
        out.shininess = ns.clamp(1.0, 1e5);
    }
    out
}

fn obj_meshes_by_material(
    path: &Path,
    models: Vec<tobj::Model>,
    materials: std::result::Result<Vec<tobj::Material>, tobj::LoadError>,
) -> Result<(Vec<Mesh>, Vec<Material>)> {
    let mtl: Vec<(String, Material)> = match materials {
        Ok(m) => m.iter().map(|m| (m.name.clone(), material_from_mtl(m))).collect(),
        Err(e) => {
            log::warn!("{}: materials not loaded ({e}); default grey", path.display());
            Vec::new()
        }
    };
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut meshes = Vec::new();
    let mut out_materials = Vec::new();
    // Group by material (None: no material or one the .mtl lacks).
    let mut groups: Vec<Option<usize>> = models.iter().map(|m| m.mesh.material_id.filter(|&i| i < mtl.len())).collect();
    groups.sort();
    groups.dedup();
    for group in groups {
        let (mut positions, mut normals, mut indices, mut all_normals) = (Vec::new(), Vec::new(), Vec::new(), true);
        for m in models.iter().filter(|m| m.mesh.material_id.filter(|&i| i < mtl.len()) == group) {
            let base = positions.len() as u32;
            let p = &m.mesh.positions;
            positions.extend(p.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
            if m.mesh.normals.len() == p.len() {
                normals.extend(m.mesh.normals.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
            } else {
                all_normals = false;
            }
            let nverts = (p.len() / 3) as u32;
            for &i in &m.mesh.indices {
                if i >= nverts {
                    return Err(SceneError::invalid(
                        path,
                        format!("object '{}': index {i} out of range ({nverts} vertices)", m.name),
                    ));
                }
                indices.push(base + i);
            }
        }
        if positions.is_empty() {
            continue;
        }
        let name = match group {
            Some(i) => format!("{stem}:{}", mtl[i].0),
            None => stem.clone(),
        };
        meshes.push(Mesh::new(path, &name, positions, all_normals.then_some(normals), indices)?);
        out_materials.push(group.map_or(Material::diffuse(Vec3::splat(0.8)), |i| mtl[i].1));
    }
    if meshes.is_empty() {
        return Err(SceneError::invalid(path, "no vertices (not an OBJ mesh?)"));
    }
    Ok((meshes, out_materials))
}

/// Load a glTF 2.0 file (.gltf or .glb): the default scene's node hierarchy with transforms, every
/// triangle primitive as a mesh (once per glTF mesh, however many nodes use it), base colour / metallic /
/// roughness factors as materials, skins and animation clips (see [`super::gltf_import`]).
/// `material_base` offsets the material indices (materials are appended to a scene's list).
///
/// Malformed files are errors naming the file, never a crash: the `gltf` crates panic on some inputs they
/// fail to validate (out-of-range accessors, `unreachable!`, assertions), so the import runs under
/// `engine_io::catch_quiet` (no panic message is printed); and the node graph is checked to be a forest
/// (glTF 2.0 §3.5.3: no cycles, no node with two parents) before any mesh is copied. The file and its external
/// buffers are read through `engine_io` (regular files of at most `Limit::MESH`); images are never read (the
/// renderer uses no textures).
pub fn load_gltf(path: &Path, material_base: usize) -> Result<GltfScene> {
    let bytes = engine_io::read(path, engine_io::Limit::MESH)?;
    engine_io::catch_quiet(|| load_gltf_unguarded(path, &bytes, material_base))
        .unwrap_or_else(|_| Err(SceneError::invalid(path, "not a valid glTF file (the glTF decoder panicked on it)")))
}

/// glTF 2.0 §3.5.3: "the node hierarchy MUST be a set of disjoint strict trees": no node is its own
/// ancestor and none has two parents. Checked on the indices alone, before anything is copied (a node
/// that was its own child used to be expanded a million times, copying its mesh on every visit).
fn check_node_forest(doc: &gltf::Document) -> std::result::Result<(), String> {
    let n = doc.nodes().len();
    let mut parent: Vec<Option<usize>> = vec![None; n];
    for node in doc.nodes() {
        for child in node.children() {
            let c = child.index();
            if c == node.index() {
                return Err(format!("node {c} is its own child"));
            }
            if let Some(p) = parent[c] {
                return Err(format!("node {c} has two parents ({p} and {})", node.index()));
            }
            parent[c] = Some(node.index());
        }
    }
    // With one parent each, a cycle is a parent chain that comes back to a node on it. Walk each chain
    // up once, marking the nodes on it (1) and, when it ends at a root or a checked node, done (2): O(n).
    let mut state = vec![0u8; n];
    let mut chain = Vec::new();
    for start in 0..n {
        let mut at = Some(start);
        while let Some(i) = at {
            match state[i] {
                1 => return Err(format!("node {i} is its own ancestor (a cycle)")),
                2 => break,
                _ => {
                    state[i] = 1;
                    chain.push(i);
                    at = parent[i];
                }
            }
        }
        for i in chain.drain(..) {
            state[i] = 2;
        }
    }
    Ok(())
}

/// A binary glTF's header (glTF 2.0 §4.4.2: magic, version, total length) checked against the file's own length.
/// `gltf::import` reads a GLB through `Glb::from_reader`, which allocates the header's length before reading
/// it: an 18-byte file could ask for 4 GiB (found by the fuzzer, tools/fuzz/corpus/glb). Loading from the bytes
/// read (`Gltf::from_slice`) with this check first bounds every allocation by the file's size.
fn check_glb_header(bytes: &[u8]) -> std::result::Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let word = |i: usize| bytes.get(i..i + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(format!("binary glTF header truncated ({} bytes)", bytes.len()));
    };
    if version != 2 {
        return Err(format!("binary glTF version {version} (only 2 is supported)"));
    }
    if (length as usize) < 20 || length as usize > bytes.len() {
        return Err(format!("binary glTF header gives a length of {length} bytes; the file has {}", bytes.len()));
    }
    Ok(())
}

/// Where a glTF URI that is no data URI names a file: inside the model's folder ([`engine_io::ModelFolder`]:
/// traversal, absolute paths, `file:` URIs and symbolic links out are refused). glTF 2.0 §3.2: relative URIs are
/// percent-encoded; any other scheme is refused. `what` names the referrer (`buffer 0`, `image 2`).
fn resolve_uri(folder: &engine_io::ModelFolder, what: &str, uri: &str) -> std::result::Result<PathBuf, String> {
    let refused = |m: &str| format!("{what}: URI {} {m}", engine_io::quote(uri));
    let scheme = uri.find(':').filter(|&i| {
        let s = &uri[..i];
        s.len() > 1
            && s.starts_with(|c: char| c.is_ascii_alphabetic())
            && s.chars().all(|c| c.is_ascii_alphanumeric() || "+.-".contains(c))
    });
    if let Some(i) = scheme {
        if !uri[..i].eq_ignore_ascii_case("file") {
            return Err(refused(
                "has an unsupported scheme; a model may name only data: URIs and files inside its own folder",
            ));
        }
    }
    let decoded = urlencoding::decode(uri).map_err(|_| refused("is not UTF-8 once percent-decoded"))?;
    folder.resolve(None, &decoded).map_err(|m| refused(&m))
}

/// The buffers of a glTF: the GLB's binary chunk, data URIs (decoded by the `gltf` crate, which reads no file for
/// them), and external files inside the model's folder ([`resolve_uri`]) read through `engine_io`
/// (`gltf::import_buffers` would read any file whole, anywhere, `/dev/zero` and FIFOs included, and panics on a
/// relative URI that percent-decodes to invalid UTF-8). Each buffer must hold at least its `byteLength`. Images are
/// never read (the renderer uses no textures), but their URIs obey the same rule, checked here: a model that names
/// a file outside its folder is refused whatever the file is for.
fn read_buffers(doc: &gltf::Document, path: &Path, mut blob: Option<Vec<u8>>) -> Result<Vec<gltf::buffer::Data>> {
    let invalid = |m: String| SceneError::invalid(path, format!("not a valid glTF file: {m}"));
    let folder = std::cell::OnceCell::new();
    let folder = || -> Result<&engine_io::ModelFolder> {
        if folder.get().is_none() {
            let _ = folder.set(engine_io::ModelFolder::of(path)?);
        }
        Ok(folder.get().expect("set above"))
    };
    for image in doc.images() {
        if let gltf::image::Source::Uri { uri, .. } = image.source() {
            if !uri.starts_with("data:") {
                resolve_uri(folder()?, &format!("image {}", image.index()), uri)
                    .map_err(|m| SceneError::invalid(path, m))?;
            }
        }
    }
    let mut out = Vec::new();
    for b in doc.buffers() {
        let external = match b.source() {
            gltf::buffer::Source::Uri(uri) if !uri.starts_with("data:") => {
                let full = resolve_uri(folder()?, &format!("buffer {}", b.index()), uri)
                    .map_err(|m| SceneError::invalid(path, m))?;
                let mut bytes = engine_io::read(&full, engine_io::Limit::MESH)
                    .map_err(|e| invalid(format!("buffer {}: {e}", b.index())))?;
                if bytes.len() < b.length() {
                    return Err(invalid(format!(
                        "buffer {}: {}: has {} bytes; its byteLength is {}",
                        b.index(),
                        full.display(),
                        bytes.len(),
                        b.length()
                    )));
                }
                bytes.resize(bytes.len().next_multiple_of(4), 0);
                Some(gltf::buffer::Data(bytes))
            }
            _ => None,
        };
        let data = match external {
            Some(d) => d,
            None => gltf::buffer::Data::from_source_and_blob(b.source(), None, &mut blob)
                .map_err(|e| invalid(format!("buffer {}: {e}", b.index())))?,
        };
        if data.len() < b.length() {
            return Err(invalid(format!(
                "buffer {} has {} bytes; its byteLength is {}",
                b.index(),
                data.len(),
                b.length()
            )));
        }
        out.push(data);
    }
    Ok(out)
}

fn load_gltf_unguarded(path: &Path, bytes: &[u8], material_base: usize) -> Result<GltfScene> {
    let invalid = |e: String| SceneError::invalid(path, format!("not a valid glTF file: {e}"));
    check_glb_header(bytes).map_err(invalid)?;
    let gltf::Gltf { document: doc, blob } = super::gltf_import::parse(bytes).map_err(invalid)?;
    // Buffers only: the renderer reads no textures, so images (external files too) are not loaded.
    let buffers = read_buffers(&doc, path, blob)?;
    check_node_forest(&doc).map_err(|m| SceneError::invalid(path, format!("not a valid glTF file: {m}")))?;
    super::gltf_import::read(path, &doc, &buffers, material_base)
}
