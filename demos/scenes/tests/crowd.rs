//! The `crowd` scene (demos/scenes/src/crowd.rs), CPU side: its options, its counts (every character with its own
//! skinned meshes, bones and shipped fitted spheres), its motion (characters out of step), and examples/crowd.toml
//! as the same scene. The GPU side renders it with every registered scene (tests/tests/scenes.rs, the artefact gate).

use scenes::crowd;

/// `examples/crowd.toml` is written by `crowd::scene_file`; set `WRITE_CROWD_EXAMPLE=1` to rewrite it.
#[test]
fn the_example_scene_file_is_the_generators_output() {
    let path = scenes::assets_dir().join("../examples/crowd.toml");
    let fresh = crowd::scene_file(&crowd::members(64, "grid", 1.6));
    if std::env::var_os("WRITE_CROWD_EXAMPLE").is_some() {
        std::fs::write(&path, &fresh).unwrap();
    }
    let shipped = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(shipped == fresh, "{} drifted from crowd::scene_file: rerun with WRITE_CROWD_EXAMPLE=1", path.display());
}

#[test]
fn the_scene_file_builds_the_registered_scene() {
    let registered = scenes::build("crowd", None).unwrap();
    let file =
        scenes::load(&scenes::assets_dir().join("../examples/crowd.toml").to_string_lossy(), None, &Default::default())
            .unwrap();
    let (a, b) = (&registered, &file.scene);
    assert_eq!(a.meshes.len(), b.meshes.len());
    assert_eq!(a.instances.len(), b.instances.len());
    for (i, (x, y)) in a.instances.iter().zip(&b.instances).enumerate() {
        assert_eq!((x.mesh, x.material), (y.mesh, y.material), "instance {i}");
        assert!(x.transform.abs_diff_eq(y.transform, 1e-5), "instance {i}: {} vs {}", x.transform, y.transform);
    }
    for (m, (x, y)) in a.meshes.iter().zip(&b.meshes).enumerate() {
        assert_eq!(x.positions, y.positions, "mesh {m}");
    }
    assert_eq!(a.blockers.spheres, b.blockers.spheres);
    assert_eq!(a.blockers.bones, b.blockers.bones);
    assert_eq!(a.lights, b.lights);
    assert_eq!(a.camera, b.camera);
    assert_eq!(a.materials, b.materials);
    assert_eq!(a.environment_intensity, b.environment_intensity);
    // The motions agree: the registered scene's motion and the file's clips pose the same bones.
    let motion = scenes::Animation::for_entry(scenes::find("crowd").unwrap(), a).unwrap();
    let clips = file.animation.expect("the file's clips");
    for t in [0.0, 0.4, 1.3, 7.9] {
        let (p, q) = (motion.pose(t).bones.unwrap(), clips.pose(t).bones.unwrap());
        assert_eq!(p.len(), q.len());
        for (k, (x, y)) in p.iter().zip(&q).enumerate() {
            assert!(x.abs_diff_eq(*y, 1e-5), "t = {t}: bone {k}");
        }
    }
}

#[test]
fn counts_options_and_motion() {
    for (spec, n) in [("crowd:count=1", 1), ("crowd:count=4", 4), ("crowd:count=5,layout=ring", 5), ("crowd", 64)] {
        let scene = scenes::build(spec, None).unwrap();
        let entry = scenes::find(spec).unwrap();
        scenes::check(entry, &scene).unwrap();
        // Two skinned meshes (body, prop) per character, then the ground.
        assert_eq!(scene.instances.len(), 2 * n + 1, "{spec}");
        assert_eq!(scene.blockers.bones.len(), 14 * n, "{spec}");
        let skinned = (0..scene.meshes.len()).filter(|&m| scene.blockers.skin_of(m).is_some()).count();
        assert_eq!(skinned, 2 * n, "{spec}");
        let spheres: usize = (0..scene.meshes.len()).map(|m| scene.blockers.spheres_of(m).map_or(0, <[_]>::len)).sum();
        assert_eq!(spheres, 2 * crowd::SPHERES_PER_MESH * n, "{spec}");
        assert!(scene.blockers.is_plane(scene.meshes.len() - 1), "{spec}: the ground is a plane blocker");
        // No two characters stand closer than the spacing (grid) or nearly so (ring).
        let m = crowd::members(n, if spec.contains("ring") { "ring" } else { "grid" }, 1.6);
        for i in 0..n {
            for j in 0..i {
                assert!(m[i].at.distance(m[j].at) > 1.5, "{spec}: {i} and {j} overlap");
            }
        }
    }
    // Characters out of step: at one time, two walkers of the same kind hold different poses.
    let scene = scenes::build("crowd:count=8", None).unwrap();
    let a = scenes::Animation::for_entry(scenes::find("crowd").unwrap(), &scene).unwrap();
    let bones = a.pose(0.5).bones.unwrap();
    let m = crowd::members(8, "grid", 1.6);
    let walkers: Vec<usize> = (0..8).filter(|&i| m[i].kind == 0 && m[i].clip == "walk").collect();
    assert!(walkers.len() >= 2 && m[walkers[0]].phase != m[walkers[1]].phase);
    assert_ne!(bones[14 * walkers[0]..14 * walkers[0] + 14], bones[14 * walkers[1]..14 * walkers[1] + 14]);
    // frame=64 keeps the view of 64 characters whatever the count.
    let one = scenes::build("crowd:count=1,frame=64", None).unwrap();
    let all = scenes::build("crowd", None).unwrap();
    assert_eq!((one.camera, one.lights.clone()), (all.camera, all.lights.clone()));
    assert_ne!(scenes::build("crowd:count=1", None).unwrap().camera, all.camera);
    // Bad options are errors naming them; other scenes take none.
    for (spec, says) in [
        ("crowd:count=0", "count"),
        ("crowd:count=2000", "count"),
        ("crowd:layout=square", "layout"),
        ("crowd:people=3", "people"),
        ("crowd:frame=-1", "frame"),
        ("battle:count=3", "no options"),
    ] {
        let e = format!("{:#}", scenes::build(spec, None).unwrap_err());
        assert!(e.contains(says), "{spec}: {e}");
    }
}
