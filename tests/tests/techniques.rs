//! Every registered technique (engine::passes::shade::TECHNIQUES), held to the tolerances it states in
//! its registry entry: a new technique is tested by being registered.
//!
//! - furnace: a Lambertian plane under a constant environment, nothing above it: ρL;
//! - unoccluded: a convex diffuse sphere under a smooth sky, no blockers: equal to `none`;
//! - one sphere over a plane under a constant environment: ρL (1 − h r²/d³) where the cap lies wholly
//!   above the horizon (shadowing techniques only);
//! - a ball above a plane blocker (half-space or rectangle) under a constant environment: ρL (1 + n_y)/2,
//!   the upper hemisphere only (shadowing techniques only);
//! - hard scenes: receivers inside spheres, hundreds of overlapping spheres, grazing views: finite;
//! - bad options: unknown keys and out-of-range values of every key are errors naming the key.
//!
//! Monte Carlo techniques (`samples > 0`) accumulate that many samples per pixel first.

use engine::gpu::Gpu;
use engine::math::envmap::LatLongMap;
use engine::options::Kind;
use engine::passes::shade::{parse_technique, TechniqueEntry, TECHNIQUES};
use engine::renderer::{RenderSettings, Renderer};
use engine::scene::Scene;
use engine_tests::{cap_cosine_fraction, relative_rmse, Receiver};
use glam::{DVec3, Vec3};
use lab::converge;

const W: u32 = 48;
const H: u32 = 36;

/// Render `scene` with `entry` at its default options (accumulating `samples` if Monte Carlo);
/// returns the radiance and the receivers.
fn render(gpu: &Gpu, scene: &Scene, entry: &TechniqueEntry) -> (Vec<f32>, Vec<Receiver>) {
    render_samples(gpu, scene, entry, entry.tolerances.samples)
}

/// [`render`] with `samples` per pixel for a Monte Carlo technique (0: one frame).
fn render_samples(gpu: &Gpu, scene: &Scene, entry: &TechniqueEntry, samples: u32) -> (Vec<f32>, Vec<Receiver>) {
    let settings = RenderSettings { width: W, height: H, technique: entry.name.into(), ..Default::default() };
    let mut r = Renderer::new(gpu, scene, settings).expect("renderer");
    if samples > 0 {
        converge::converge(gpu, &mut r, 0.0, samples).expect("accumulate");
    } else {
        r.render(gpu).expect("frame");
    }
    let hdr = r.read_radiance(gpu).expect("radiance");
    let pos = gpu.read_image_rgba32f(&r.gbuffer.position).expect("positions");
    let nrm = gpu.read_image_rgba32f(&r.gbuffer.normal).expect("normals");
    r.destroy(gpu);
    let v = |img: &[f32], i: usize| DVec3::new(img[4 * i] as f64, img[4 * i + 1] as f64, img[4 * i + 2] as f64);
    let g = (0..(W * H) as usize)
        .map(|i| (pos[4 * i + 3] >= 0.5).then(|| (v(&pos, i), v(&nrm, i).normalize(), (pos[4 * i + 3] - 0.5) as usize)))
        .collect();
    (hdr, g)
}

fn assert_finite(hdr: &[f32], what: &str) {
    assert!(hdr.iter().all(|v| v.is_finite()), "{what}: a non-finite value reached the image");
}

#[test]
fn furnace_every_technique() {
    let gpu = engine_tests::gpu();
    let (albedo, l) = (0.5f32, 2.0f32);
    let scene = scenes::furnace::scene(albedo, l);
    for entry in TECHNIQUES {
        let (hdr, g) = render(&gpu, &scene, entry);
        assert_finite(&hdr, entry.name);
        let want: Vec<f32> = g.iter().flat_map(|_| [albedo * l, albedo * l, albedo * l, 1.0]).collect();
        let covered = |i: usize| g[i].is_some();
        assert!((0..g.len()).filter(|&i| covered(i)).count() > 100, "the plane is in view");
        let e = relative_rmse(&hdr, &want, covered);
        eprintln!("{}: furnace relative RMSE {e:.2e} (tolerance {:.1e})", entry.name, entry.tolerances.furnace);
        assert!(e <= entry.tolerances.furnace, "{}: furnace {e} > {}", entry.name, entry.tolerances.furnace);
    }
    gpu.shutdown().expect("clean teardown");
}

#[test]
fn no_blockers_equals_none() {
    let gpu = engine_tests::gpu();
    // A convex diffuse sphere: nothing occludes it but its own tangent plane, in every technique.
    let scene = scenes::sphere::scene(24);
    let none = TECHNIQUES.iter().find(|t| t.name == "none").expect("none is registered");
    let (base, g) = render(&gpu, &scene, none);
    for entry in TECHNIQUES {
        let (hdr, _) = render(&gpu, &scene, entry);
        assert_finite(&hdr, entry.name);
        let e = relative_rmse(&hdr, &base, |i| g[i].is_some());
        let bound = entry.tolerances.unoccluded_vs_none;
        eprintln!("{}: against none without blockers {e:.2e} (bound {bound:.1e})", entry.name);
        assert!(e <= bound.max(1e-6), "{}: {e} against none > {bound}", entry.name);
    }
    gpu.shutdown().expect("clean teardown");
}

#[test]
fn one_sphere_over_a_plane_every_shadowing_technique() {
    let gpu = engine_tests::gpu();
    let (albedo, l) = (0.6f32, 1.5f32);
    let (c, r) = (Vec3::new(0.0, 0.8, 0.0), 0.5f32);
    let scene = engine_tests::fixtures::sphere_over_plane(LatLongMap::constant(64, 32, [l; 3]), albedo, c, r);
    for entry in TECHNIQUES {
        let Some(bound) = entry.tolerances.one_sphere else { continue };
        let (hdr, g) = render(&gpu, &scene, entry);
        assert_finite(&hdr, entry.name);
        let rho_l = albedo * l;
        let mut want = vec![0f32; hdr.len()];
        let mut mask = vec![false; g.len()];
        for (i, px) in g.iter().enumerate() {
            // Plane pixels (material 0) whose cap is wholly above the horizon.
            let Some((p, _, 0)) = *px else { continue };
            let Some(f) = cap_cosine_fraction(p, c.as_dvec3(), r as f64) else { continue };
            want[4 * i..4 * i + 3].fill(rho_l * (1.0 - f as f32));
            mask[i] = true;
        }
        let shadowed = (0..g.len()).filter(|&i| mask[i] && want[4 * i] < 0.95 * rho_l).count();
        assert!(shadowed > 20, "the shadow is in view ({shadowed} pixels)");
        let e = relative_rmse(&hdr, &want, |i| mask[i]);
        eprintln!(
            "{}: one sphere against the closed form {:.3} % (bound {:.1} %)",
            entry.name,
            100.0 * e,
            100.0 * bound
        );
        assert!(e <= bound, "{}: one sphere {e} > {bound}", entry.name);
    }
    gpu.shutdown().expect("clean teardown");
}

#[test]
fn ball_above_a_plane_every_shadowing_technique() {
    use engine_tests::fixtures::{ball_above_ground, GroundBlocker};
    let gpu = engine_tests::gpu();
    let (albedo, l) = (0.7f32, 1.5f32);
    for blocker in [GroundBlocker::HalfSpace, GroundBlocker::Rectangle] {
        let env = LatLongMap::constant(64, 32, [l; 3]);
        let scene = ball_above_ground(env, albedo, Vec3::new(0.0, 0.6, 0.0), 0.4, blocker);
        for entry in TECHNIQUES {
            let Some(bound) = entry.tolerances.one_plane else { continue };
            let (hdr, g) = render(&gpu, &scene, entry);
            assert_finite(&hdr, entry.name);
            let mut want = vec![0f32; hdr.len()];
            let mut mask = vec![false; g.len()];
            for (i, px) in g.iter().enumerate() {
                // Ball pixels: the upper hemisphere only.
                let Some((_, n, 0)) = *px else { continue };
                want[4 * i..4 * i + 3].fill(albedo * l * (1.0 + n.y as f32) / 2.0);
                mask[i] = true;
            }
            let covered = mask.iter().filter(|&&m| m).count();
            let facing_down = (0..g.len()).filter(|&i| mask[i] && want[4 * i] < 0.3 * albedo * l).count();
            assert!(
                covered > 300 && facing_down > 20,
                "the ball and its underside are in view ({covered}, {facing_down})"
            );
            let e = relative_rmse(&hdr, &want, |i| mask[i]);
            eprintln!(
                "{} ({blocker:?}): ball above a plane against the closed form {:.3} % (bound {:.1} %)",
                entry.name,
                100.0 * e,
                100.0 * bound
            );
            assert!(e <= bound, "{} ({blocker:?}): ball above a plane {e} > {bound}", entry.name);
        }
    }
    gpu.shutdown().expect("clean teardown");
}

#[test]
fn hard_scenes_stay_finite() {
    let gpu = engine_tests::gpu();
    let mut scene = engine_tests::fixtures::sphere_over_plane(
        LatLongMap::constant(64, 32, [1.0; 3]),
        0.5,
        Vec3::new(0.0, 0.8, 0.0),
        0.5,
    );
    // Three hundred overlapping spheres around the blocker, some through the plane (plane receivers
    // inside spheres), one containing the camera's view of the sphere's surface (receivers inside),
    // one of zero radius and coincident duplicates.
    let mut spheres: Vec<engine::blockers::Sphere> = (0..300)
        .map(|i| {
            let t = i as f64 * 0.37;
            let y = -1.8 + 3.6 * (i as f64 / 299.0);
            engine::blockers::Sphere::new(DVec3::new(t.cos() * 0.9, y, t.sin() * 0.9), 0.35)
        })
        .collect();
    spheres.push(engine::blockers::Sphere::new(DVec3::ZERO, 1.2));
    spheres.push(engine::blockers::Sphere::new(DVec3::new(0.0, 2.0, 0.0), 0.0));
    spheres.push(spheres[0]);
    scene.blockers.spheres[1] = Some(spheres);
    // A grazing view: the camera just above the plane.
    let mut grazing = scene.clone();
    grazing.camera.eye = Vec3::new(0.0, 0.02, 2.8);
    grazing.camera.target = Vec3::new(0.0, 0.0, -1.0);
    for entry in TECHNIQUES {
        for (s, what) in [(&scene, "overlapping"), (&grazing, "grazing")] {
            // One frame: finiteness does not need a converged estimate.
            let (hdr, g) = render_samples(&gpu, s, entry, 0);
            assert!(g.iter().any(|p| p.is_some()), "{what}: something in view");
            assert_finite(&hdr, &format!("{} ({what})", entry.name));
            assert!(hdr.iter().all(|v| *v >= 0.0), "{} ({what}): negative radiance", entry.name);
        }
    }
    gpu.shutdown().expect("clean teardown");
}

/// Bad options of every registered technique: an unknown key, and for each key a value outside
/// what it accepts; the error names the key. No GPU needed.
#[test]
fn bad_options_name_the_key() {
    for entry in TECHNIQUES {
        let e = parse_technique(&format!("{}:no_such_key=1", entry.name)).err().expect("unknown key fails").to_string();
        assert!(e.contains("no_such_key"), "{}: {e}", entry.name);
        assert!(parse_technique(&format!("{}:novalue", entry.name)).is_err());
        for o in entry.options {
            let bad: Vec<String> = match o.kind {
                Kind::Int { min, max } => vec![(min - 1).to_string(), (max + 1).to_string(), "1.5".into(), "x".into()],
                Kind::Float { min, max, .. } => {
                    let mut v = vec!["nan".to_string(), "inf".to_string(), "x".to_string(), (min - 1.0).to_string()];
                    if max.is_finite() {
                        v.push((max + 1.0).to_string());
                    }
                    v
                }
                Kind::Choice(_) => vec!["no-such-choice".into(), String::new()],
                Kind::Direction => vec!["0/0/0".into(), "1/2".into()],
            };
            for v in bad {
                let spec = format!("{}:{}={v}", entry.name, o.key);
                let e = parse_technique(&spec).err().unwrap_or_else(|| panic!("{spec} parsed")).to_string();
                assert!(e.contains(&format!("'{}'", o.key)), "{spec}: {e}");
            }
            // The default parses, and so does the key alone with its default value.
            if let Some(d) = o.default {
                parse_technique(&format!("{}:{}={d}", entry.name, o.key)).expect("the default parses");
            }
        }
        parse_technique(entry.name).expect("no options");
    }
    // An unknown technique is an option error (it was a GPU error, `GpuError::Other`), and stays one when it
    // reaches a GPU-side call.
    let typed: engine::options::OptionError = parse_technique("no-such-technique").err().expect("unknown name");
    assert!(matches!(engine::gpu::GpuError::from(typed), engine::gpu::GpuError::Option(_)));
    let e = parse_technique("no-such-technique").err().expect("unknown name").to_string();
    for entry in TECHNIQUES {
        assert!(e.contains(entry.name), "the error lists '{}': {e}", entry.name);
    }
}

/// The option tables of the technique docs are the registry's: each technique with options has its page
/// docs/techniques/<name>.md, where its table, generated by `engine::options::markdown_table`, appears verbatim
/// (and the README links that page).
#[test]
fn technique_docs_option_tables_match_the_registry() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let readme = std::fs::read_to_string(format!("{root}/README.md")).expect("README.md");
    for entry in TECHNIQUES.iter().filter(|e| !e.options.is_empty()) {
        let page = format!("docs/techniques/{}.md", entry.name);
        let doc = std::fs::read_to_string(format!("{root}/{page}")).unwrap_or_else(|e| panic!("{page}: {e}"));
        let table = engine::options::markdown_table(entry.options);
        assert!(
            doc.contains(&table),
            "{page} lacks the option table of '{}' as the registry generates it:\n{table}",
            entry.name
        );
        assert!(readme.contains(&format!("]({page})")), "README.md does not link {page}");
    }
}

/// Scene and option errors raised inside the passes are typed as such, not as GPU failures (`GpuError::Other`):
/// an environment with a NaN texel is a scene error where the reference builds its sampling tables, and a
/// `pixel_clusters=world` scene past the G-buffer's vertex limit is a scene error that names the way out.
#[test]
fn pass_level_refusals_are_typed_scene_errors() {
    use engine::gpu::GpuError;
    use engine::passes::shade::shexp::{check_world_pixel_vertices, ShexpOptions, MAX_WORLD_PIXEL_VERTICES};
    let mut env = engine::math::envmap::LatLongMap::constant(8, 4, [1.0; 3]);
    env.texels[5] = [f32::NAN, 0.0, 0.0];
    let Err(e) = engine::passes::shade::reference::EnvSampling::build(&env) else { panic!("a NaN texel is refused") };
    assert!(matches!(&e, GpuError::Scene(_)) && e.to_string().contains("texel 5"), "{e:?}");
    let o = ShexpOptions { world_pixel_clusters: true, ..Default::default() };
    let Err(e) = check_world_pixel_vertices(&o, MAX_WORLD_PIXEL_VERTICES + 1) else { panic!("too many vertices") };
    assert!(matches!(&e, GpuError::Scene(_)) && e.to_string().contains("pixel_clusters=tiles"), "{e:?}");
    assert!(check_world_pixel_vertices(&o, MAX_WORLD_PIXEL_VERTICES).is_ok());
}
