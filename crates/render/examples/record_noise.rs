//! How noisy one irradiance record is, and what it costs: the figures behind the renderer's
//! sampling choices (`docs/renderer.md`).
//!
//! At `P` points the camera sees (a jittered grid over the image, emitters skipped), `K`
//! independent hemisphere estimates each; prints the mean over the points of the estimates'
//! relative variance of luminance (variance over the squared mean), and the time one estimate
//! takes. The variance times the time is the figure of merit: a change that lowers it needs fewer
//! rays for the same noise.
//!
//! ```sh
//! cargo run --release --example record_noise -- cornell 512 [points] [estimates]
//! ```

// The renderer is compiled out under the model checkers (`cfg(checker)`, set by build.rs).
#[cfg(not(checker))]
mod app {
    use std::time::Instant;
    use wfic::rng::Rng;
    use wfic_render::integrator::{facing, sample_irradiance, RayCounts, Strata};
    use wfic_render::scene::luminance;
    use wfic_render::scenes;

    pub fn main() {
        let args: Vec<String> = std::env::args().collect();
        let name = args.get(1).map_or("cornell", String::as_str);
        // A number argument, its default when absent; a bad one is refused, not replaced.
        let number = |i: usize, what: &str, default: u32, min: u32| -> u32 {
            let Some(arg) = args.get(i) else {
                return default;
            };
            match arg.parse::<u32>() {
                Ok(v) if v >= min => v,
                _ => {
                    eprintln!("record_noise: {what} must be a whole number of at least {min}, got `{arg}`");
                    std::process::exit(2);
                }
            }
        };
        let rays = number(2, "rays per record", 512, 6);
        let points = number(3, "points", 64, 2);
        let estimates = number(4, "estimates", 48, 2);
        let scene = match scenes::load(name) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(2);
            }
        };
        let view = scene.camera().view(256, 256);
        let eps = 1e-4 * scene.diagonal();
        let strata = Strata::for_rays(rays);
        let mut pick = Rng::new(7);
        let mut rel_var = Vec::new();
        let mut seconds = 0.0f64;
        let mut rays_counted = RayCounts::default();
        let side = (points as f32).sqrt().ceil() as u32;
        let mut tries = 0;
        while rel_var.len() < points as usize && tries < 50 * points {
            tries += 1;
            let (gx, gy) = (tries % side, (tries / side) % side);
            let px = (gx as f32 + pick.next_f32()) / side as f32 * 256.0;
            let py = (gy as f32 + pick.next_f32()) / side as f32 * 256.0;
            let dir = view.direction(px, py);
            let Some(hit) = scene.intersect(view.eye(), dir, f32::INFINITY) else {
                continue;
            };
            if hit.material.is_emissive() {
                continue;
            }
            let x = view.eye() + dir * hit.t;
            let n = facing(hit.normal, dir);
            let mut lum = Vec::with_capacity(estimates as usize);
            let start = Instant::now();
            for k in 0..estimates {
                let mut rng = Rng::new(0x5eed ^ (u64::from(k) << 20) ^ u64::from(tries));
                let s = sample_irradiance(&scene, x, n, strata, eps, &mut rng, &mut rays_counted);
                lum.push(f64::from(luminance(s.irradiance)));
            }
            seconds += start.elapsed().as_secs_f64();
            let mean = lum.iter().sum::<f64>() / lum.len() as f64;
            if mean <= 0.0 {
                continue;
            }
            let var = lum.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / (lum.len() - 1) as f64;
            rel_var.push(var / (mean * mean));
        }
        if rel_var.len() < 2 {
            eprintln!(
                "record_noise: {name}: only {} of {points} points see a lit, non-emitting surface",
                rel_var.len()
            );
            std::process::exit(1);
        }
        let n = rel_var.len() as f64;
        let mean_rv = rel_var.iter().sum::<f64>() / n;
        // The spread of the mean over the points, for telling two variants apart.
        let sd = (rel_var.iter().map(|v| (v - mean_rv).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let per_estimate = seconds / (n * f64::from(estimates));
        println!(
            "{name}: N {} ({} x {}), {} points x {estimates} estimates: relative variance {:.4e} \
             (+- {:.1e}), {:.1} us per estimate, variance x time {:.4e}",
            strata.rays(),
            strata.theta,
            strata.phi,
            rel_var.len(),
            mean_rv,
            sd / n.sqrt(),
            per_estimate * 1e6,
            mean_rv * per_estimate * 1e6,
        );
    }
}

#[cfg(not(checker))]
fn main() {
    app::main();
}

#[cfg(checker)]
fn main() {}
