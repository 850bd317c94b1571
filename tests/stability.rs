//! Stability suite (issue 7): scale and translation invariance, grazing rays, tiny and
//! enclosing shapes, roulette, glass, deep and coincident CSG, degenerate input. Each case
//! measures the CPU f64 image and the GPU f32 image against an answer that neither
//! renderer produced (closed form, analytic classification, or the unit-scene image); the
//! cases live in `tests/stability/cases.rs` so `examples/stability_table.rs` can print the
//! table of docs/STABILITY.md from the same code. GPU halves skip loudly without an
//! adapter (and fail with LUMEN_REQUIRE_GPU=1); the CPU halves always run.

#[path = "stability/cases.rs"]
mod cases;

use lumen::gpu::{gpu_for_tests, Gpu};

fn run(name: &str, case: fn(Option<&Gpu>) -> cases::Outcome) {
    let gpu = gpu_for_tests(name);
    case(gpu.as_ref()).check();
}

/// The glass cases' Fresnel oracle against identities that do not depend on how it is
/// computed: the normal-incidence reflectance ((η − 1)/(η + 1))², no p-reflection at
/// Brewster's angle atan η, Abelès' relation r_p = r_s² at 45° (any η), Stokes'
/// reciprocity (the same reflectance from either side of the interface), total internal
/// reflection beyond the critical angle asin(1/η), and total reflection at grazing
/// incidence.
#[test]
fn the_fresnel_oracle_obeys_the_textbook_identities() {
    use std::f64::consts::FRAC_PI_4;
    let cos = |deg: f64| deg.to_radians().cos();
    for eta in [1.33f64, 1.5, 2.4] {
        let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
        assert!((cases::fresnel(1.0, eta) - f0).abs() < 1e-15, "η {eta}");
        assert!((cases::fresnel(1.0, 1.0 / eta) - f0).abs() < 1e-15, "1/η {eta}");
        let (_, rp) = cases::fresnel_amplitudes(eta.atan().cos(), eta).unwrap();
        assert!(rp.abs() < 1e-15, "Brewster, η {eta}: r_p {rp}");
        let (rs, rp) = cases::fresnel_amplitudes(FRAC_PI_4.cos(), eta).unwrap();
        assert!((rp - rs * rs).abs() < 1e-14, "Abelès, η {eta}: r_p {rp}, r_s² {}", rs * rs);
        for deg in [5.0f64, 20.0, 40.0, 60.0, 80.0, 89.0] {
            let sin_t = deg.to_radians().sin() / eta;
            let cos_t = (1.0 - sin_t * sin_t).sqrt();
            let (outside, inside) = (cases::fresnel(cos(deg), eta), cases::fresnel(cos_t, 1.0 / eta));
            assert!((outside - inside).abs() < 1e-12, "Stokes, η {eta}, {deg}°: {outside} vs {inside}");
            assert!(outside > f0 && outside < 1.0, "η {eta}, {deg}°: {outside}");
        }
        let critical = (1.0 / eta).asin().to_degrees();
        assert_eq!(cases::fresnel(cos(critical + 0.01), 1.0 / eta), 1.0);
        assert!(cases::fresnel(cos(critical - 0.01), 1.0 / eta) < 1.0);
        assert!((cases::fresnel(0.0, eta) - 1.0).abs() < 1e-12);
    }
}

#[test]
fn scene_scaled_by_1e_minus_4_renders_like_the_unit_scene_on_the_cpu() {
    cases::scaled_down(None).check();
}

#[test]
fn scene_scaled_by_1e_minus_4_renders_like_the_unit_scene_on_the_gpu() {
    run("scaled_down", cases::scaled_down);
}

#[test]
fn scene_scaled_by_1e4_renders_like_the_unit_scene() {
    run("scaled_up", cases::scaled_up);
}

#[test]
fn scene_translated_by_1e5_renders_like_the_unit_scene() {
    run("translated", cases::translated);
}

#[test]
fn grazing_point_light_on_a_plane_matches_the_closed_form() {
    run("grazing_point_light", cases::grazing_point_light);
}

#[test]
fn plane_seen_at_grazing_angles_has_no_acne() {
    run("grazing_plane_sky", cases::grazing_plane_sky);
}

#[test]
fn sphere_silhouette_has_no_acne() {
    run("sphere_silhouette", cases::sphere_silhouette);
}

#[test]
fn cube_corner_and_edges_have_no_acne() {
    run("cube_edges", cases::cube_edges);
}

#[test]
fn closed_box_does_not_leak_light() {
    run("light_leak", cases::light_leak);
}

#[test]
fn tiny_far_sphere_covers_its_analytic_area_orthogonal() {
    run("tiny_sphere_orthogonal", cases::tiny_sphere_orthogonal);
}

#[test]
fn tiny_far_sphere_covers_its_analytic_area_narrow_perspective() {
    run("tiny_sphere_narrow", cases::tiny_sphere_narrow);
}

#[test]
fn camera_inside_a_sphere_sees_the_furnace() {
    run("inside_sphere", cases::inside_sphere);
}

#[test]
fn camera_inside_a_cube_sees_the_furnace() {
    run("inside_cube", cases::inside_cube);
}

#[test]
fn camera_inside_a_cube_with_nee_is_unbiased() {
    run("inside_cube_nee", cases::inside_cube_nee);
}

#[test]
fn closed_box_furnace_with_albedo_0_99_and_roulette_is_unbiased() {
    run("furnace_roulette", cases::furnace_roulette);
}

#[test]
fn many_paths_per_camera_sample_on_the_cpu() {
    cases::many_paths_per_sample(None).check();
}

#[test]
fn many_paths_per_camera_sample_on_the_gpu() {
    run("many_paths_per_sample", cases::many_paths_per_sample);
}

#[test]
fn glass_rim_internal_reflections_depth_3() {
    run("glass_rim_depth_3", cases::glass_rim_depth_3);
}

#[test]
fn glass_rim_conserves_energy_depth_64() {
    run("glass_rim_depth_64", cases::glass_rim_depth_64);
}

#[test]
fn glass_cube_total_internal_reflection_path_lengths() {
    run("glass_cube_tir", cases::glass_cube_tir);
}

#[test]
fn csg_nested_8_deep_matches_set_membership() {
    run("csg_nested_8", cases::csg_nested_8);
}

#[test]
fn csg_diff_with_coincident_faces_has_no_speckles() {
    run("csg_coincident_sides", |gpu| cases::csg_coincident_sides(gpu, false));
}

#[test]
fn csg_diff_with_faces_coincident_up_to_rounding_has_no_speckles() {
    run("csg_coincident_sides_rotated", |gpu| cases::csg_coincident_sides(gpu, true));
}

#[test]
fn csg_diff_touching_along_a_face_stays_closed() {
    run("csg_touching_face", cases::csg_touching_face);
}

#[test]
fn degenerate_scripts_are_load_errors() {
    cases::degenerate_scripts().check();
}

#[test]
fn extreme_valid_scales_render_without_nan() {
    run("extreme_transforms", cases::extreme_transforms);
}

#[test]
fn script_scales_1e_minus_300_and_1e18_render_without_nan() {
    run("extreme_script_scales_1e18", |gpu| cases::extreme_script_scales(gpu, "1e18"));
}

#[test]
fn script_scale_1e30_on_the_cpu() {
    cases::extreme_script_scales(None, "1e30").check();
}

#[test]
fn script_scale_1e30_on_the_gpu() {
    run("extreme_script_scales_1e30", |gpu| cases::extreme_script_scales(gpu, "1e30"));
}

#[test]
fn script_scale_1e300() {
    run("extreme_script_scales_1e300", |gpu| cases::extreme_script_scales(gpu, "1e300"));
}
