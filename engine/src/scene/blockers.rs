//! Blocker sphere sets and skinning of a scene (plain data, no Vulkan).
//!
//! - Sphere sets are per mesh, in the mesh's object space ([`SceneBlockers::spheres`]); every instance of
//!   a mesh with a set contributes its spheres, moved by the instance transform every frame.
//! - Skinning is linear blend skinning: a mesh may have a [`Skin`] (up to four bones per vertex); bone
//!   matrices ([`SceneBlockers::bones`]) map the mesh's rest pose to its posed object space (identity =
//!   rest) and are shared by every skinned mesh. The skin pass and the sphere pass read the same bone
//!   matrices, so spheres follow the skin (SHEXP §6.2 "Animation").
//! - A skinned mesh's spheres are bound to bones at rest by [`bind_sphere_to_bones`]: the skin weights of
//!   the vertices near the sphere, averaged. SHEXP binds by mean value coordinates of the centre w.r.t.
//!   the rest mesh, then folds them into bone weights; averaging the weights of nearby vertices is the
//!   same idea with a local kernel instead of MVCs (cheap, and equal for rigidly moving parts).
//! - Thin shells (ISG §5, cloth): a mesh marked thin ([`SceneBlockers::thin`]) has no sphere set; its own
//!   triangles are its blockers (every instance's, in world space, following skin and transform). The
//!   mark is per mesh, like sphere sets: thinness is a property of the geometry, not of where an
//!   instance puts it, and a mesh's blocker representation is chosen once for all its instances.

use super::Mesh;
use engine_blockers::file::{load_or_fit, CacheOutcome};
use engine_blockers::fit::FitSettings;
pub use engine_blockers::BlockerPlane;
use engine_blockers::Sphere;
use glam::{Mat4, Vec3};
use std::path::Path;

/// Per-vertex bone influences of one mesh (`joints[v][k]` with weight `weights[v][k]`; weights of a
/// vertex sum to 1, or to 0 for a vertex that follows the instance transform only).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skin {
    pub joints: Vec<[u32; 4]>,
    pub weights: Vec<[f32; 4]>,
}

/// The scene's blockers and skinning. `Default`: no spheres, no skins, no bones.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneBlockers {
    /// Sphere set per mesh (index = mesh index; missing or `None`: the mesh casts no sphere shadows).
    pub spheres: Vec<Option<Vec<Sphere>>>,
    /// Skin per mesh (index = mesh index; missing or `None`: rigid).
    pub skins: Vec<Option<Skin>>,
    /// Bone matrices at the scene's initial pose (the renderer rewrites them per frame).
    pub bones: Vec<Mat4>,
    /// Thin-shell mark per mesh (index = mesh index; missing: not thin). A thin mesh's triangles are
    /// its blockers; it must have no sphere set.
    pub thin: Vec<bool>,
    /// Plane blockers given in world space (half-spaces or rectangles: the ground as a blocker).
    pub planes: Vec<BlockerPlane>,
    /// Plane mark per mesh (index = mesh index; missing: not a plane). Every instance of a marked mesh
    /// becomes a rectangle plane blocker (`BlockerPlane::from_flat_mesh` of its world-space vertices:
    /// it must be a flat rectangle); it must have no sphere set and not be thin.
    pub plane_meshes: Vec<bool>,
    /// The simulated cloth, if any ([`super::cloth`]): a thin grid mesh moved by the `cloth` pass, with
    /// blocker spheres generated along it every frame for the techniques that do not read thin shells.
    pub cloth: Option<super::cloth::Cloth>,
}

impl SceneBlockers {
    pub fn spheres_of(&self, mesh: usize) -> Option<&[Sphere]> {
        self.spheres.get(mesh).and_then(|s| s.as_deref())
    }
    pub fn skin_of(&self, mesh: usize) -> Option<&Skin> {
        self.skins.get(mesh).and_then(|s| s.as_ref())
    }
    pub fn is_thin(&self, mesh: usize) -> bool {
        self.thin.get(mesh).copied().unwrap_or(false)
    }
    pub fn is_plane(&self, mesh: usize) -> bool {
        self.plane_meshes.get(mesh).copied().unwrap_or(false)
    }
}

/// Bone influences of a sphere at rest: the skin weights of the mesh vertices within the sphere (or,
/// when none is, of the 8 nearest vertices), weighted by `1 − d/R` with R the largest of those
/// distances plus a margin, summed per bone; the four largest are kept and normalized. All-zero
/// weights (a rigid region) give all-zero weights (the sphere then follows the instance only).
pub fn bind_sphere_to_bones(sphere: &Sphere, positions: &[Vec3], skin: &Skin) -> ([u32; 4], [f32; 4]) {
    let c = sphere.center.as_vec3();
    let mut near: Vec<(f32, usize)> = positions.iter().enumerate().map(|(i, p)| (p.distance(c), i)).collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    let inside = near.iter().take_while(|(d, _)| *d <= sphere.radius as f32).count();
    near.truncate(inside.max(8));
    let reach = near.last().map_or(0.0, |n| n.0) * 1.25 + 1e-6;
    let mut acc: Vec<(u32, f32)> = Vec::new();
    for &(d, v) in &near {
        let k = 1.0 - d / reach;
        let (Some(j), Some(w)) = (skin.joints.get(v), skin.weights.get(v)) else { continue };
        for s in 0..4 {
            if w[s] > 0.0 {
                match acc.iter_mut().find(|a| a.0 == j[s]) {
                    Some(a) => a.1 += k * w[s],
                    None => acc.push((j[s], k * w[s])),
                }
            }
        }
    }
    acc.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    acc.truncate(4);
    let total: f32 = acc.iter().map(|a| a.1).sum();
    let mut joints = [0u32; 4];
    let mut weights = [0f32; 4];
    if total > 0.0 {
        for (k, (j, w)) in acc.into_iter().enumerate() {
            joints[k] = j;
            weights[k] = w / total;
        }
    }
    (joints, weights)
}

/// The fit-once sphere set of a scene mesh: loads `cache` when it matches the mesh and `settings`,
/// otherwise fits (engine_blockers, SHEXP §6.2) and rewrites it. Logs when it fits.
pub fn fitted_spheres(mesh: &Mesh, settings: &FitSettings, cache: &Path) -> Result<Vec<Sphere>, super::SceneError> {
    let err = |m: String| super::SceneError::invalid(cache, m);
    let positions = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
    let triangles = mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    let bmesh = engine_blockers::mesh::Mesh::new(positions, triangles).map_err(|e| err(e.to_string()))?;
    let outcome = load_or_fit(&bmesh, &mesh.name, settings, cache, &mut |_| {}).map_err(|e| err(e.to_string()))?;
    if let CacheOutcome::Fitted { reason, .. } = &outcome {
        log::info!("{}: fitted {} spheres to '{}' ({reason})", cache.display(), settings.count, mesh.name);
    }
    Ok(outcome.spheres().to_vec())
}

/// What [`cached_spheres`] made or found.
#[derive(Clone, Debug)]
pub struct CachedSpheres {
    pub spheres: Vec<Sphere>,
    /// The cache file.
    pub file: std::path::PathBuf,
    /// Whether it fitted (the cache missed).
    pub fitted: bool,
    /// The count asked, when the mesh supports fewer spheres and that many were fitted instead (see
    /// [`cached_spheres`]), with the mesh's sample points (surface, interior).
    pub capped: Option<(usize, (usize, usize))>,
}

/// The fit-once sphere set of `mesh` in the folder `cache_dir`, the file named by the mesh's content hash and the
/// sphere count (`<hash>-n<count>.spheres.json`), so any number of meshes share one folder and an edited mesh gets
/// a new file. `progress` sees every fit iteration.
///
/// A mesh supports at most as many spheres as the fit has sample points (every vertex, every triangle midpoint and
/// the interior grid points): when `settings.count` is more, that many are fitted instead and
/// [`CachedSpheres::capped`] says so (a small model, such as Khronos' 18-point SimpleSkin, was an error under the
/// default 32 spheres).
pub fn cached_spheres(
    mesh: &Mesh,
    settings: &FitSettings,
    cache_dir: &Path,
    progress: &mut dyn FnMut(&engine_blockers::fit::FitProgress),
) -> Result<CachedSpheres, super::SceneError> {
    let err = |p: &Path, m: String| super::SceneError::invalid(p, m);
    let positions = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
    let triangles = mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    let bmesh = engine_blockers::mesh::Mesh::new(positions, triangles)
        .map_err(|e| err(cache_dir, format!("mesh '{}': {e}", mesh.name)))?;
    let (surface, interior) = engine_blockers::fit::sample_points(&bmesh, settings);
    let supported = surface + interior;
    let mut settings = settings.clone();
    let capped = (settings.count > supported).then_some((settings.count, (surface, interior)));
    settings.count = settings.count.min(supported);
    let hash = bmesh.content_hash();
    let short: String = hash.rsplit(':').next().unwrap_or("").chars().filter(|c| c.is_ascii_hexdigit()).collect();
    let file = cache_dir.join(format!("{short}-n{}.spheres.json", settings.count));
    std::fs::create_dir_all(cache_dir).map_err(|e| err(cache_dir, format!("cannot create the sphere cache: {e}")))?;
    let outcome = load_or_fit(&bmesh, &mesh.name, &settings, &file, progress).map_err(|e| err(&file, e.to_string()))?;
    let fitted = matches!(outcome, CacheOutcome::Fitted { .. });
    Ok(CachedSpheres { spheres: outcome.spheres().to_vec(), file, fitted, capped })
}

/// Load a sphere file for `mesh`, refusing one fitted to another mesh (its recorded content hash differs).
pub fn spheres_for_mesh(mesh: &Mesh, file: &Path) -> Result<Vec<Sphere>, super::SceneError> {
    let err = |m: String| super::SceneError::invalid(file, m);
    let text = engine_io::read_to_string(file, engine_io::Limit::SPHERES)?;
    let set =
        engine_blockers::file::SphereSetFile::from_json(&text, &file.display().to_string()).map_err(|e| match e {
            // The format error names the file itself: keep its message only.
            engine_blockers::BlockerError::Format { message, .. } => err(format!("not a valid sphere file: {message}")),
            other => err(other.to_string()),
        })?;
    let positions = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
    let triangles = mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    let bmesh = engine_blockers::mesh::Mesh::new(positions, triangles).map_err(|e| err(e.to_string()))?;
    if set.mesh_hash != bmesh.content_hash() {
        return Err(err(format!(
            "the spheres were fitted to another mesh ('{}', hash {}), not to '{}' (hash {})",
            set.source_mesh,
            set.mesh_hash,
            mesh.name,
            bmesh.content_hash()
        )));
    }
    set.spheres().map_err(|e| err(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn binding_follows_nearby_weights() {
        let positions: Vec<Vec3> = (0..=20).map(|i| Vec3::new(i as f32 * 0.1, 0.0, 0.0)).collect();
        // Bone 0 left of x = 1, bone 1 right of it, a linear blend over [0.8, 1.2].
        let skin = Skin {
            joints: vec![[0, 1, 0, 0]; 21],
            weights: positions
                .iter()
                .map(|p| {
                    let t = ((p.x - 0.8) / 0.4).clamp(0.0, 1.0);
                    [1.0 - t, t, 0.0, 0.0]
                })
                .collect(),
        };
        let left = bind_sphere_to_bones(&Sphere::new(DVec3::new(0.3, 0.0, 0.0), 0.25), &positions, &skin);
        assert_eq!(left, ([0, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]));
        let right = bind_sphere_to_bones(&Sphere::new(DVec3::new(1.7, 0.0, 0.0), 0.25), &positions, &skin);
        assert_eq!(right.0[0], 1);
        assert!((right.1[0] - 1.0).abs() < 1e-6);
        let mid = bind_sphere_to_bones(&Sphere::new(DVec3::new(1.0, 0.0, 0.0), 0.15), &positions, &skin);
        assert!((mid.1.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        assert!(mid.1[0] > 0.3 && mid.1[1] > 0.3, "{mid:?}");
        // A rigid mesh (all weights zero) binds to nothing.
        let rigid = Skin { joints: vec![[0; 4]; 21], weights: vec![[0.0; 4]; 21] };
        assert_eq!(bind_sphere_to_bones(&Sphere::new(DVec3::ZERO, 0.3), &positions, &rigid).1, [0.0; 4]);
    }
}
