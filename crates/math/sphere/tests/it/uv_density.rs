//! `Param::uv_density` (the map Jacobian) against the exact texel solid
//! angles, and the f32 direction→map functions against the f64 ones.

use glam::{DVec2, Vec3};
use relight_sphere::Param;
use relight_sphere::param::{
    hemi_octahedral_from_dir, hemi_octahedral_from_dir_f32, octahedral_from_dir,
    octahedral_from_dir_f32,
};

#[test]
fn uv_density_integrates_to_the_exact_texel_solid_angles() {
    for p in [
        Param::LatLong {
            width: 16,
            height: 8,
        },
        Param::Cube { n: 6 },
        Param::Octahedral { n: 8 },
        Param::HemiOctahedral { n: 8 },
    ] {
        let q = 64;
        let (w, h) = (p.width() as f64, p.height() as f64);
        for i in 0..p.len() {
            let (c, r) = p.col_row(i);
            let mut sum = 0.0;
            for k in 0..q * q {
                let uv = DVec2::new(
                    (c as f64 + ((k % q) as f64 + 0.5) / q as f64) / w,
                    (r as f64 + ((k / q) as f64 + 0.5) / q as f64) / h,
                );
                sum += p.uv_density(uv);
            }
            sum /= (q * q) as f64 * w * h;
            let exact = p.texel_solid_angle(i);
            assert!(
                (sum - exact).abs() < 1e-3 * exact,
                "{p:?} texel {i}: quadrature {sum} vs exact {exact}"
            );
        }
    }
}

#[test]
fn f32_map_coordinates_match_f64() {
    for k in 0..500 {
        let z = 1.0 - 2.0 * (k as f32 + 0.5) / 500.0;
        let a = k as f32 * 2.399_963;
        let s = (1.0 - z * z).sqrt();
        let d = Vec3::new(s * a.cos(), s * a.sin(), z);
        let o = octahedral_from_dir(d.as_dvec3()).as_vec2();
        assert!((octahedral_from_dir_f32(d) - o).length() < 1e-5, "{d}");
        let hm = hemi_octahedral_from_dir(d.as_dvec3()).as_vec2();
        assert!(
            (hemi_octahedral_from_dir_f32(d) - hm).length() < 1e-5,
            "{d}"
        );
    }
}
