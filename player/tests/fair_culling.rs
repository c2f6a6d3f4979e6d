//! Issue 30 item 2, fair culling: `frustum` mode's originals get the hybrid
//! originals' per-tile normal-cone and frustum tests (not the patch bitfields,
//! which are not exact), switched by the same `--no-backface` / `--no-frustum` and
//! recorded in every report's `draw_options`. Culled and unculled frames are
//! identical pixel for pixel along the demo walk, with fewer triangles; `full`
//! (the reference) is never culled.

mod common;
use common::{demo_walk, open_player, per_triangle_patches};
use player::frame::Mode;
use player::run::camera_for;
use player::testdata::write_synthetic_bake;

#[test]
fn frustum_mode_per_tile_culling_is_exact() {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake(dir.path()).unwrap();
    let base_path = dir.path().join("base.pack");
    let mut base = format::pack::BasePack::read(&base_path).unwrap();
    base.patches = Some(per_triangle_patches(&base));
    base.write(&base_path).unwrap();
    let size = (160, 120);
    let Some(mut p) = open_player(dir.path(), size, &player::DrawOptions::default()) else {
        return;
    };
    assert!(
        p.bake.exact_patches.is_some(),
        "the synthetic bake has patches"
    );
    let no_cull = player::DrawOptions {
        backface: false,
        frustum: false,
        ..Default::default()
    };
    let Some(mut q) = open_player(dir.path(), size, &no_cull) else {
        return;
    };
    assert!(q.bake.exact_patches.is_none());
    let path = demo_walk();
    let (mut culled_tris, mut all_tris, mut compared) = (0u64, 0u64, 0);
    for f in path.frames().iter().step_by(4) {
        let cam = camera_for(f, &path, size, p.bake.extent);
        let (_, a, _, _) = p.draw(&cam, Mode::Frustum, None);
        let culled = p.renderer.read_pixels().unwrap();
        let (_, b, _, _) = q.draw(&cam, Mode::Frustum, None);
        let all = q.renderer.read_pixels().unwrap();
        let differing = culled
            .chunks_exact(4)
            .zip(all.chunks_exact(4))
            .filter(|(x, y)| x != y)
            .count();
        assert_eq!(
            differing, 0,
            "t={:.2}s: per-tile culling changed {differing} pixels",
            f.time_s
        );
        assert!(a <= b, "t={:.2}s: {a} > {b}", f.time_s);
        // Full geometry is the reference: never culled.
        let (_, full_p, _, _) = p.draw(&cam, Mode::Full, None);
        let (_, full_q, _, _) = q.draw(&cam, Mode::Full, None);
        assert_eq!(full_p, full_q);
        culled_tris += a;
        all_tris += b;
        compared += 1;
    }
    println!(
        "{compared} frames identical; frustum mode kept {culled_tris} of {all_tris} triangles"
    );
    assert!(
        culled_tris < all_tris,
        "the per-tile tests remove something"
    );
}
