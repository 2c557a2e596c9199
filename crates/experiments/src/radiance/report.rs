//! The comparison's report: `radiance.md` (the matched rows, the time at equal error, the
//! image noise against light samples, the sweep, the cross-check), `radiance.csv` (every run)
//! and the side-by-side images.

use super::{RadianceConfig, Role, Run, SceneComparison};
use crate::harness::metrics::ImageError;
use crate::harness::table::{pct, Table};
use image::{Rgb, RgbImage};
use std::path::Path;
use wfic_render::film::Image;
use wfic_render::scene::luminance;

/// A false-colour map of `|L - L_ref| / L_ref` (black 0, through red, to yellow-white at 20% and
/// above), grey where the pixel is not measured; each measured pixel of the `stride` grid fills
/// its `stride` x `stride` block. RGB bytes.
fn error_map(img: &Image, reference: &Image, mask: &[bool], stride: u32) -> Vec<u8> {
    let (w, h) = (img.width(), img.height());
    let on_grid = |v: u32, n: u32| (v / stride * stride + stride / 2).min(n - 1);
    (0..w * h)
        .flat_map(|i| {
            let j = (on_grid(i / w, h) * w + on_grid(i % w, w)) as usize;
            if !mask[j] {
                return [60, 60, 60];
            }
            let (la, lb) = (luminance(img.pixels()[j]), luminance(reference.pixels()[j]));
            let e = if lb > 0.0 {
                ((la - lb).abs() / lb / 0.2).min(1.0)
            } else {
                1.0
            };
            [0.0, 1.0, 2.0].map(|c| ((e * 3.0 - c).clamp(0.0, 1.0) * 255.0) as u8)
        })
        .collect()
}

/// Radiance's cached image beside wfic's (one exposure for both), their error maps against
/// their own references below.
pub fn write_side_by_side(
    path: &Path,
    [radiance, wfic]: [&Image; 2],
    [radiance_ref, wfic_ref]: [&Image; 2],
    mask: &[bool],
    stride: u32,
) -> Result<(), String> {
    let (w, h, gap) = (wfic.width(), wfic.height(), 8);
    let exposure = wfic.auto_exposure();
    let mut canvas = RgbImage::from_pixel(2 * w + gap, 2 * h + gap, Rgb([255; 3]));
    let tiles = [
        (0, 0, radiance.to_srgb8(exposure)),
        (w + gap, 0, wfic.to_srgb8(exposure)),
        (0, h + gap, error_map(radiance, radiance_ref, mask, stride)),
        (w + gap, h + gap, error_map(wfic, wfic_ref, mask, stride)),
    ];
    for (x, y, rgb) in tiles {
        let tile = RgbImage::from_raw(w, h, rgb).expect("a w x h RGB image");
        image::imageops::replace(&mut canvas, &tile, x.into(), y.into());
    }
    canvas
        .save(path)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// The goal column of the equal-error table: `yes` when the wfic run in `role` (a pick that
/// reached Radiance's error) errs at or below Radiance's run `rad` and takes at most 0.1x its
/// time. The pick comes from the sweep's frame, so the frame rendered again can err above: it
/// says so.
pub fn speed_goal(role: Role, wf: &Run, rad: &Run) -> &'static str {
    if !matches!(role, Role::Pick { reached: true, .. }) {
        "NO"
    } else if wf.cache_error.rel_rmse > rad.cache_error.rel_rmse {
        "NO: error above"
    } else if wf.seconds <= 0.1 * rad.seconds {
        "yes"
    } else {
        "NO"
    }
}

/// Seconds as the tables give them.
fn secs(seconds: f64) -> String {
    format!("{seconds:.3}")
}

/// An error as `rel. RMSE (mean rel.)`; `n/a` where there is none (NaN: no image to measure
/// against).
fn both(e: &ImageError) -> String {
    if e.rel_rmse.is_nan() {
        return "n/a".to_owned();
    }
    format!("{} ({})", pct(e.rel_rmse), pct(e.mean_rel))
}

/// A percentage, or `n/a` for NaN (a row with nothing of that kind to measure).
fn pct_or_na(x: f64) -> String {
    if x.is_nan() {
        "n/a".to_owned()
    } else {
        pct(x)
    }
}

/// A row's mean cache error, with the range of its renders when there were several.
fn with_range(run: &Run) -> String {
    let (e, (lo, hi)) = (pct(run.cache_error.rel_rmse), run.cache_error_range);
    if run.repeats > 1 {
        format!("{e} ({}–{})", pct(lo), pct(hi))
    } else {
        e
    }
}

/// A wfic row's setting as the tables name it: `a 0.15 N 320 r_min 6 px`, with `k 1.5` after it
/// when the row smooths.
pub fn wfic_setting(run: &Run) -> String {
    let (a, n, r) = (run.accuracy, run.rays, run.min_radius_pixels);
    format!("a {a} N {n} r_min {r} px{}", smoothing_label(run))
}

/// ` k K` for a row that smooths (K above 1), else nothing.
fn smoothing_label(run: &Run) -> String {
    if run.smoothing > 1.0 {
        format!(" k {}", run.smoothing)
    } else {
        String::new()
    }
}

/// The page's opening: the settings of both renderers.
fn intro(config: &RadianceConfig, version: &str) -> String {
    let ((w, h), n, a, k) = (
        config.size,
        config.rays,
        config.accuracy,
        config.reference_stride,
    );
    let (ar, l, n4) = (config.resolution, config.light_samples, 4 * n);
    let (converged, repeats) = (config.converged_light_samples, config.repeats.max(1));
    let passes = config.converged_passes.max(1);
    let nc = n4 * passes;
    format!(
        "Radiance: {version}.\n\n\
         How to read this page: docs/experiments.md#radiance-side-by-side.\n\n\
         {w} x {h}, one ray per pixel. Radiance: `rtrace -ab 1 -ad {n} -as 0 -aa {a} -ar {ar} \
         -av 0 0 0 -aw 0 -dj 0 -lw 1e-7 -n P -af FILE`; reference `-aa 0 -ad {n4}`. wfic: `wf`, \
         accuracy {a}, {n} rays per record, {l} light samples; reference `--scheme none` with \
         {n4} rays. Converged references: Radiance `-aa 0 -ad {n4} {}`, {passes} rays a \
         pixel averaged; wfic `none`, {nc} rays, {converged} light \
         samples, another seed. Errors on one pixel of every {k} x {k} block. Every row but the \
         references is {repeats} render(s) of its setting.\n",
        super::rtrace::CONVERGED_DIRECT
    )
}

/// A scene's run paired with the scene's comparison, a row of the tables.
type Row<'a> = (&'a SceneComparison, &'a Run);

/// The matched rows and each pick's, at 1 and 2 workers (each beside its 1-worker row).
fn matched_markdown(results: &[SceneComparison]) -> String {
    let picks = [None, Some(1), Some(2)]
        .into_iter()
        .flat_map(|w| [true, false].map(|reached| ("wfic", Role::pick(reached, w))));
    let roles: Vec<_> = [
        ("radiance", Role::Matched),
        (super::schedule::ORIGINAL, Role::Matched),
        ("wfic", Role::Matched),
    ]
    .into_iter()
    .chain(picks)
    .collect();
    let mut rows: Vec<(Row, &Run)> = Vec::new();
    for r in results {
        for &(renderer, role) in &roles {
            if let (Some(one), Some(two)) = (r.find(renderer, role, 1), r.find(renderer, role, 2)) {
                rows.extend([((r, one), one), ((r, two), one)]);
            }
        }
    }
    let setting = |run: &Run| {
        let (l, r) = (run.light_samples, run.min_radius_pixels);
        let wfic = (run.renderer == "wfic")
            .then(|| format!(" L {l} r_min {r} px{}", smoothing_label(run)));
        let (role, a, n) = (run.role.name(), run.accuracy, run.rays);
        format!("{role}: a {a} N {n}{}", wfic.unwrap_or_default())
    };
    let records = |run: &Run, one: &Run| {
        let ratio = run.records as f64 / one.records.max(1) as f64;
        if run.workers == 2 {
            format!("{ratio:.3}")
        } else {
            String::new()
        }
    };
    Table::new()
        .md("scene", |((r, _), _): &(Row, &Run)| r.scene.clone())
        .left()
        .md("triangles", |((r, _), _)| r.triangles.to_string())
        .md("source", |((r, _), _)| r.source.to_owned())
        .left()
        .md("renderer", |((_, run), _)| run.renderer.to_owned())
        .left()
        .md("workers", |((_, run), _)| run.workers.to_string())
        .md("setting", move |((_, run), _)| setting(run))
        .left()
        .md("seconds", |((_, run), _)| secs(run.seconds))
        .md("records", |((_, run), _)| run.records.to_string())
        .md("records 2/1", move |((_, run), one)| records(run, one))
        .md("cache error", |((_, run), _)| both(&run.cache_error))
        .md("image error", |((_, run), _)| both(&run.image_error))
        .md("image error, own converged", |((_, run), _)| {
            both(&run.own_image_error)
        })
        .markdown(&rows)
}

/// The image goal: the pick reached Radiance's image error (each against its own converged
/// image) in at most a tenth of its time.
pub fn image_goal(wf: &Run, rad: &Run) -> &'static str {
    match wf.role {
        Role::ImagePick { reached: true, .. }
            if wf.own_image_error.rel_rmse <= rad.own_image_error.rel_rmse =>
        {
            if wf.seconds <= 0.1 * rad.seconds {
                "yes"
            } else {
                "NO"
            }
        }
        _ => "NO: error above",
    }
}

/// Each scene's rows at 1 and 2 workers: the scene, Radiance's matched run and wfic's run that
/// `pick` chooses at that worker count, where both exist.
fn beside_radiance<'a>(
    results: &'a [SceneComparison],
    pick: impl Fn(&'a SceneComparison, usize) -> Option<&'a Run>,
) -> Vec<(&'a SceneComparison, &'a Run, &'a Run)> {
    let mut rows = Vec::new();
    for r in results {
        for workers in [1, 2] {
            if let (Some(wf), Some(rad)) =
                (pick(r, workers), r.find("radiance", Role::Matched, workers))
            {
                rows.push((r, rad, wf));
            }
        }
    }
    rows
}

/// The time at equal image error, each scene's worker counts: Radiance's matched row beside
/// the count's image pick.
fn equal_image_markdown(results: &[SceneComparison]) -> String {
    let rows = beside_radiance(results, |r, workers| {
        [true, false]
            .into_iter()
            .find_map(|reached| r.find("wfic", Role::ImagePick { reached, workers }, workers))
    });
    let t = Table::new()
        .md("scene", |(r, ..): &(&SceneComparison, &Run, &Run)| {
            r.scene.clone()
        })
        .left()
        .md("workers", |(_, _, wf)| wf.workers.to_string())
        .md("radiance s", |(_, rad, _)| secs(rad.seconds))
        .md(
            "radiance image error: own converged, wfic's",
            |(_, rad, _)| {
                format!(
                    "{}, {}",
                    pct(rad.own_image_error.rel_rmse),
                    pct(rad.image_error.rel_rmse)
                )
            },
        )
        .md("wfic setting", |(_, _, wf)| {
            format!(
                "{}: {} L {}",
                wf.role.name(),
                wfic_setting(wf),
                wf.light_samples
            )
        })
        .left()
        .md("wfic s", |(_, _, wf)| secs(wf.seconds))
        .md("wfic image error", |(_, _, wf)| {
            pct(wf.own_image_error.rel_rmse)
        })
        .md("time ratio wfic/radiance", |(_, rad, wf)| {
            format!("{:.4}", wf.seconds / rad.seconds)
        })
        .md("goal <= 0.1", |(_, rad, wf)| image_goal(wf, rad).to_owned())
        .left();
    format!("\n## Time at equal image error\n\n{}", t.markdown(&rows))
}

/// The extra records of the pick in `role` at 2 workers over 1.
fn extra_records(r: &SceneComparison, role: Role) -> f64 {
    match (r.find("wfic", role, 1), r.find("wfic", role, 2)) {
        (Some(a), Some(b)) => b.records as f64 / a.records.max(1) as f64 - 1.0,
        _ => f64::NAN,
    }
}

/// The time at equal error, each scene's worker counts: Radiance's matched row beside the
/// count's pick at that count.
fn equal_error_markdown(results: &[SceneComparison]) -> String {
    let rows = beside_radiance(results, |r, workers| {
        // This worker count's pick: one setting for both counts, or one each.
        let own = [None, None, Some(workers), Some(workers)];
        own.into_iter()
            .zip([true, false, true, false])
            .find_map(|(w, ok)| r.find("wfic", Role::pick(ok, w), workers))
    });
    let t = Table::new()
        .md("scene", |(r, ..): &(&SceneComparison, &Run, &Run)| {
            r.scene.clone()
        })
        .left()
        .md("workers", |(_, _, wf)| wf.workers.to_string())
        .md("radiance s", |(_, rad, _)| secs(rad.seconds))
        .md("radiance cache error (range)", |(_, rad, _)| {
            with_range(rad)
        })
        .md("wfic setting", |(_, _, wf)| {
            format!("{}: {}", wf.role.name(), wfic_setting(wf))
        })
        .left()
        .md("wfic s", |(_, _, wf)| secs(wf.seconds))
        .md("wfic cache error (range)", |(_, _, wf)| with_range(wf))
        .md("time ratio wfic/radiance", |(_, rad, wf)| {
            format!("{:.4}", wf.seconds / rad.seconds)
        })
        .md("goal <= 0.1", |(_, rad, wf)| {
            speed_goal(wf.role, wf, rad).to_owned()
        })
        .left()
        .md("extra records at 2 (wfic)", |(r, _, wf)| {
            pct(extra_records(r, wf.role))
        })
        .md("goal <= 2%", |(r, _, wf)| {
            if extra_records(r, wf.role) <= 0.02 {
                "yes"
            } else {
                "NO"
            }
            .to_owned()
        })
        .left();
    format!("\n## Time at equal error\n\n{}", t.markdown(&rows))
}

/// One row of the light-sample table: a scene's count, at 2 threads and 1, against Radiance at
/// 1 and 2 workers, and whether it is at or below Radiance's image error.
struct Light<'a> {
    scene: &'a str,
    two: &'a Run,
    one: &'a Run,
    rad: [&'a Run; 2],
    verdict: &'static str,
}

/// Image noise against light samples at the pick: each count at 2 threads (1 thread beside
/// it), and whether it is at or below Radiance's image error; the smallest such count marked.
fn light_markdown(results: &[SceneComparison]) -> String {
    let mut rows = Vec::new();
    for r in results {
        let Some(rad) = r.find("radiance", Role::Matched, 1) else {
            continue;
        };
        let rad = [rad, r.find("radiance", Role::Matched, 2).unwrap_or(rad)];
        let light = |workers| {
            r.runs
                .iter()
                .filter(move |x| x.role == Role::LightSamples && x.workers == workers)
        };
        let mut first = true;
        for two in light(2) {
            let one = light(1)
                .find(|x| x.light_samples == two.light_samples)
                .unwrap_or(two);
            let meets = two.image_error.rel_rmse <= rad[0].image_error.rel_rmse;
            let verdict = match (meets, first) {
                (true, true) => "**yes: the smallest count**",
                (true, false) => "yes",
                _ => "no",
            };
            rows.push(Light {
                scene: &r.scene,
                two,
                one,
                rad,
                verdict,
            });
            first &= !meets;
        }
    }
    let t = Table::new()
        .md("scene", |l: &Light| l.scene.to_owned())
        .left()
        .md("radiance image error (1 worker)", |l| {
            pct(l.rad[0].image_error.rel_rmse)
        })
        .md("light samples", |l| l.two.light_samples.to_string())
        .md("wfic s, 1 thread", |l| secs(l.one.seconds))
        .md("wfic s, 2 threads", |l| secs(l.two.seconds))
        .md("wfic image error", |l| pct(l.two.image_error.rel_rmse))
        .md("at or below radiance", |l| l.verdict.to_owned())
        .left()
        .md("time ratio to radiance, 1 / 2 workers", |l| {
            let (one, two) = (
                l.one.seconds / l.rad[0].seconds,
                l.two.seconds / l.rad[1].seconds,
            );
            format!("{one:.4} / {two:.4}")
        })
        .left();
    format!(
        "\n## Image noise against light samples (wfic at the equal-error cache setting)\n\n{}",
        t.markdown(&rows)
    )
}

/// The sweep and the references, and the cross-check of both renderers' brute force.
fn sweep_markdown(results: &[SceneComparison]) -> String {
    let rows: Vec<Row> = every_run(results)
        .into_iter()
        .filter(|(_, run)| {
            matches!(
                run.role,
                Role::Sweep | Role::ImageSweep | Role::Reference | Role::Converged
            )
        })
        .collect();
    let cross = Table::new()
        .md("scene", |r: &SceneComparison| r.scene.clone())
        .left()
        .md("Radiance brute force vs converged wfic: error", |r| {
            both(&r.cross_check)
        })
        .md("mean luminance ratio", |r| format!("{:.4}", r.mean_ratio))
        .md("emitting triangles: Radiance's sources", |r| {
            let (triangles, spheres, polygons, _) = r.sources;
            let plural =
                |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
            format!(
                "{triangles}: {}, {}",
                plural(spheres, "sphere"),
                plural(polygons, "polygon")
            )
        })
        .md("emitted power, Radiance / wfic", |r| {
            format!("{:.4}", r.sources.3)
        })
        .md("rtrace load + 1 ray (s)", |r| secs(r.radiance_load_seconds))
        .md("oconv (s)", |r| secs(r.oconv_seconds));
    format!(
        "\n## The sweeps (wfic, 2 threads: the cache sweep at the matched light samples; the image sweep, its fastest front with more light samples), the references and the converged images\n\n{}\n\
         ## Cross-check and load times\n\n{}",
        runs_table().markdown(&rows),
        cross.markdown(results)
    )
}

/// `radiance.md`'s body.
pub fn markdown(config: &RadianceConfig, results: &[SceneComparison], version: &str) -> String {
    [
        intro(config, version),
        matched_markdown(results),
        equal_error_markdown(results),
        equal_image_markdown(results),
        light_markdown(results),
        sweep_markdown(results),
        "\nSide-by-side images: `SCENE-side-by-side.png`.\n".to_owned(),
    ]
    .concat()
}

/// Every run of every scene, with its scene.
fn every_run(results: &[SceneComparison]) -> Vec<Row<'_>> {
    results
        .iter()
        .flat_map(|r| r.runs.iter().map(move |run| (r, run)))
        .collect()
}

/// The runs' table: the Markdown sweep table's columns and the CSV's, defined once.
fn runs_table<'a>() -> Table<'a, Row<'a>> {
    let e6 = |x: f64| format!("{x:.6}");
    Table::new()
        .col("scene", "scene", |(r, _): &Row| r.scene.clone())
        .left()
        .csv("triangles", |(r, _)| r.triangles.to_string())
        .csv("source", |(r, _)| r.source.to_owned())
        .col("renderer", "renderer", |(_, x)| x.renderer.to_owned())
        .left()
        .col("role", "role", |(_, x)| x.role.name().to_owned())
        .left()
        .csv("workers", |(_, x)| x.workers.to_string())
        .col("a", "accuracy", |(_, x)| x.accuracy.to_string())
        .col("N", "rays", |(_, x)| x.rays.to_string())
        .col("L", "light_samples", |(_, x)| x.light_samples.to_string())
        .col("r_min px", "min_radius_pixels", |(_, x)| {
            x.min_radius_pixels.to_string()
        })
        .col("k", "smoothing", |(_, x)| x.smoothing.to_string())
        .col("seconds", "seconds", |(_, x)| secs(x.seconds))
        .csv_as(|(_, x)| format!("{:.4}", x.seconds))
        .col("records", "records", |(_, x)| x.records.to_string())
        .col("cache error", "cache_rel_rmse", |(_, x)| {
            pct_or_na(x.cache_error.rel_rmse)
        })
        .csv_as(move |(_, x)| e6(x.cache_error.rel_rmse))
        .csv("cache_mean_rel", move |(_, x)| e6(x.cache_error.mean_rel))
        .col("image error", "image_rel_rmse", |(_, x)| {
            pct(x.image_error.rel_rmse)
        })
        .csv_as(move |(_, x)| e6(x.image_error.rel_rmse))
        .csv("image_mean_rel", move |(_, x)| e6(x.image_error.mean_rel))
        .csv("own_image_rel_rmse", move |(_, x)| {
            e6(x.own_image_error.rel_rmse)
        })
        .csv("own_image_mean_rel", move |(_, x)| {
            e6(x.own_image_error.mean_rel)
        })
        .csv("repeats", |(_, x)| x.repeats.to_string())
        .csv("cache_rel_rmse_min", move |(_, x)| {
            e6(x.cache_error_range.0)
        })
        .csv("cache_rel_rmse_max", move |(_, x)| {
            e6(x.cache_error_range.1)
        })
}

/// Every run as CSV.
pub fn csv(results: &[SceneComparison]) -> String {
    runs_table().csv_text(&every_run(results))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cell_with_nothing_to_measure_reads_n_a() {
        assert_eq!(pct_or_na(f64::NAN), "n/a");
        assert_eq!(pct_or_na(0.0123), "1.23%");
    }
}
