//! The lighting table × BRDF table chain on an analytic case: a linear sky
//! `L(d) = 1 + d·g` on white Lambert gives `B(n) = 1 + ⅔ g·n` exactly.

use glam::{Mat3, Vec3};
use relight_brdf::BrdfSpec;
use relight_sphere::{EnvMap, Param};
use relight_triple::brdf_table::BrdfTable;
use relight_triple::lighting::{LightTable, frame_of, prefilter};
use relight_triple::shade::shade_point;
use relight_triple::{Basis, LeafGrid, Weighting};

#[test]
fn linear_sky_on_lambert_is_exact_to_a_percent() {
    let g = Vec3::new(0.3, 0.5, -0.2);
    let env = EnvMap::from_fn(
        Param::LatLong {
            width: 256,
            height: 128,
        },
        |d| Vec3::splat(1.0 + d.dot(g)),
    );
    let pre = prefilter(&env, 3);
    let brdf = "lambert".parse::<BrdfSpec>().unwrap().build();
    let grid = LeafGrid::new(Basis::paper(), 1).unwrap();
    for m in [1, 2] {
        let table = LightTable::build(&pre, Mat3::IDENTITY, m, 1);
        let bt = BrdfTable::bake(brdf.as_ref(), &grid, m, 4, Weighting::Exact);
        let mut worst = 0.0f32;
        for n in [
            Vec3::Y,
            Vec3::X,
            Vec3::new(0.3, -0.6, 0.7).normalize(),
            Vec3::NEG_Z,
        ] {
            let f = frame_of(n);
            let lt = table.lookup(&f);
            let b = bt.lookup(Vec3::Z);
            let got = shade_point(
                &table.data,
                &lt,
                &bt.data,
                &b,
                None,
                table.stride,
                table.padded,
            );
            let want = 1.0 + 2.0 / 3.0 * g.dot(n);
            worst = worst.max((got.x - want).abs() / want);
        }
        assert!(worst < 0.01, "m {m}: relative error {worst}");
    }
}
