//! Loading an OBJ scene against its size: reading, triangulating and building the BVH, from text
//! in memory (`obj::load_from`). Two shapes, each at four sizes ten times apart:
//! - `grid/N`: an `N`-quad height field under a light, the shape of a real export;
//! - `polygon/N`: one face of `N` corners under a light, the shape that made the loader's time
//!   grow with the square of `N` before polygons were halved rather than fanned.
//!
//! The throughput is the input's bytes: `cargo bench -p wfic-render --bench obj_load` reports
//! the time per byte at each size, and linear time is a time per byte that stays flat as `N`
//! grows (docs/renderer.md, "Loading").
#[cfg(not(checker))]
mod bench {
    use criterion::{criterion_group, BenchmarkId, Criterion, Throughput};
    use std::borrow::Cow;
    use std::hint::black_box;
    use std::path::Path;
    use wfic_render::obj::{self, FileResolver};

    /// One OBJ file in memory, and the MTL it names.
    struct Text(Vec<u8>);

    const MTL: &[u8] = b"newmtl light\nKd 0 0 0\nKe 4 4 4\nnewmtl grey\nKd 0.5 0.5 0.5\n";

    impl FileResolver for Text {
        fn read(&self, path: &Path) -> std::io::Result<Cow<'static, [u8]>> {
            match path.extension().and_then(|e| e.to_str()) {
                Some("obj") => Ok(Cow::Owned(self.0.clone())),
                Some("mtl") => Ok(Cow::Borrowed(MTL)),
                _ => Err(std::io::ErrorKind::NotFound.into()),
            }
        }
    }

    /// The light over the unit square, then `body`.
    fn scene(body: &str) -> Text {
        let head = "mtllib m.mtl\nusemtl light\nv 0 2 0\nv 1 2 0\nv 1 2 1\nv 0 2 1\nf 4 3 2 1\n\
                    usemtl grey\n";
        Text(format!("{head}{body}").into_bytes())
    }

    /// `n` quads (rounded to a square) of a gently curved height field over the unit square.
    fn grid(n: usize) -> Text {
        let side = (n as f64).sqrt().round() as usize;
        let mut body = String::new();
        for j in 0..=side {
            for i in 0..=side {
                let (x, z) = (i as f32 / side as f32, j as f32 / side as f32);
                body += &format!("v {x} {} {z}\n", 0.1 * (6.0 * x).sin() * (5.0 * z).cos());
            }
        }
        let at = |i: usize, j: usize| 5 + j * (side + 1) + i;
        for j in 0..side {
            for i in 0..side {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                body += &format!("f {a} {b} {c} {d}\n");
            }
        }
        scene(&body)
    }

    /// One face of `n` corners on a circle.
    fn polygon(n: usize) -> Text {
        let mut body = String::new();
        for k in 0..n {
            let t = std::f32::consts::TAU * k as f32 / n as f32;
            body += &format!("v {} 0 {}\n", 0.5 + 0.5 * t.cos(), 0.5 + 0.5 * t.sin());
        }
        body += "f";
        for k in 0..n {
            body += &format!(" {}", 5 + k);
        }
        body.push('\n');
        scene(&body)
    }

    fn load(c: &mut Criterion) {
        let mut group = c.benchmark_group("obj_load");
        group.sample_size(10);
        for (shape, make) in [("grid", grid as fn(usize) -> Text), ("polygon", polygon)] {
            for n in [1_000, 10_000, 100_000, 1_000_000] {
                let text = make(n);
                group.throughput(Throughput::Bytes(text.0.len() as u64));
                group.bench_with_input(BenchmarkId::new(shape, n), &text, |b, text| {
                    b.iter(|| black_box(obj::load_from(Path::new("s.obj"), text).unwrap()))
                });
            }
        }
        group.finish();
    }

    criterion_group!(benches, load);
}

#[cfg(not(checker))]
criterion::criterion_main!(bench::benches);

#[cfg(checker)]
fn main() {}
