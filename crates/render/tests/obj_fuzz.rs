//! Structured fuzzing of the scene reader (`wfic_render::obj`): OBJ and MTL text, the textures an
//! MTL names, and geometry that is valid but extreme. Every input must load or be refused with an
//! [`obj::ObjError`] that names the file (and a line of it, when it names one), within a time and
//! an allocation bound, and without a panic in the reader or in a dependency (the BVH builder, the
//! image decoders). A scene that loads must also render a tiny frame with finite pixels.
//!
//! The inputs, drawn by proptest:
//! - token streams: OBJ and MTL statements with random arguments (numbers near every edge of
//!   `f32`, NaN and infinities, huge, zero and negative indices, malformed corners, stray words);
//! - valid files cut at a random byte, and valid files with a random non-UTF-8 byte put in;
//! - `mtllib` chains: many libraries, named again and again, and the OBJ file named as a library;
//! - textures: random bytes, PNG files cut short, and PNG headers that claim huge images;
//! - extreme geometry: coordinates up to `f32::MAX` and down to subnormals, degenerate and
//!   coincident triangles, and (as fixed cases) polygons of 10^5 vertices.
//!
//! `#[global_allocator]` is per binary, and this one has no libtest harness (`harness = false`):
//! the cases run one after the other on the main thread, so the peak of live bytes a case reaches
//! is its own. The bound checked: [`allowed_peak`].
//!
//! `WFIC_FUZZ_CASES` sets the number of random cases (default 10,000: CI); the whole run is
//! `WFIC_FUZZ_CASES=100000 cargo test --release -p wfic-render --test obj_fuzz`
//! (docs/verification.md).

#[cfg(checker)]
fn main() {}

#[cfg(not(checker))]
fn main() {
    real::main();
}

#[cfg(not(checker))]
mod real {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, TestCaseError, TestRunner};
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::borrow::Cow;
    use std::collections::HashMap;
    use std::path::{Path, PathBuf};
    use std::time::{Duration, Instant};
    use wfic::cache::Scheme;
    use wfic::sync::unchecked::{AtomicU64, Ordering::Relaxed};
    use wfic_render::obj::{self, FileResolver};
    use wfic_render::{render_with_scheme, RenderSettings};

    /// The system allocator, counting the live bytes and their peak.
    struct Counting;

    // Relaxed throughout: the cases run on the main thread, and a count is read only by the
    // thread that made the allocations it counts (program order suffices); no other memory is
    // published through these counters.
    static LIVE: AtomicU64 = AtomicU64::new(0);
    static PEAK: AtomicU64 = AtomicU64::new(0);

    // SAFETY: every call is forwarded to `System` with the caller's own arguments, so `System`'s
    // guarantees are the caller's; the counters do not touch the memory.
    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            // SAFETY: forwarded as is (the caller upholds `alloc`'s contract).
            let p = unsafe { System.alloc(layout) };
            if !p.is_null() {
                grow(layout.size() as u64);
            }
            p
        }

        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            // SAFETY: forwarded as is: `ptr` came from `alloc` with `layout`.
            unsafe { System.dealloc(ptr, layout) };
            LIVE.fetch_sub(layout.size() as u64, Relaxed);
        }

        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            // SAFETY: forwarded as is: `ptr` came from `alloc` with `layout`.
            let p = unsafe { System.realloc(ptr, layout, new_size) };
            if !p.is_null() {
                LIVE.fetch_sub(layout.size() as u64, Relaxed);
                grow(new_size as u64);
            }
            p
        }
    }

    fn grow(bytes: u64) {
        let live = LIVE.fetch_add(bytes, Relaxed) + bytes;
        PEAK.fetch_max(live, Relaxed);
    }

    #[global_allocator]
    static ALLOCATOR: Counting = Counting;

    /// The most a case may hold live above what was live before it, loading and rendering: 8 MiB
    /// plus 48 bytes a byte of input (the files' bytes, after gunzip). Measured over 10^5 cases:
    /// at most 12 bytes a byte of input where the input is 1 KiB or more, the most for the
    /// polygons of 3 x 10^5 corners (each triangle held as read, as a BVH primitive and in its
    /// intersection form). A texture's decoding is bounded apart, by [`obj::MAX_TEXTURE_BYTES`].
    fn allowed_peak(input_bytes: usize, textures: usize) -> u64 {
        (8 << 20) + 48 * input_bytes as u64 + textures as u64 * obj::MAX_TEXTURE_BYTES
    }

    /// The longest a case may take (a hang is a failure; the biggest fixed case loads in well
    /// under a second in release).
    const CASE_TIME: Duration = Duration::from_secs(20);

    /// A set of files in memory, by path.
    #[derive(Clone, Debug, Default)]
    struct Files(HashMap<PathBuf, Vec<u8>>);

    impl FileResolver for Files {
        fn read(&self, path: &Path) -> std::io::Result<Cow<'static, [u8]>> {
            self.0
                .get(path)
                .cloned()
                .map(Cow::Owned)
                .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"))
        }
    }

    impl Files {
        fn bytes(&self) -> usize {
            self.0.values().map(Vec::len).sum()
        }
        fn lines_of(&self, path: &Path) -> Option<usize> {
            self.0
                .get(path)
                .map(|b| 1 + b.iter().filter(|&&c| c == b'\n').count())
        }
    }

    const SCENE: &str = "fuzz/scene.obj";

    /// What a case came to.
    #[derive(Debug, Default)]
    struct Tally {
        cases: usize,
        loaded: usize,
        rendered: usize,
        refused: usize,
        worst_peak_ratio: f64,
        /// The largest peak, in bytes, and the largest peak a byte of input (of the cases whose
        /// files total at least 1 KiB, where the fixed part is small beside it).
        largest_peak: u64,
        peak_per_byte: f64,
        slowest: Duration,
    }

    /// Loads `files`' scene, renders it when it loads, and checks every promise; the error says
    /// which promise broke.
    fn check(files: &Files, tally: &mut Tally) -> Result<(), String> {
        let textures = files
            .0
            .keys()
            .filter(|p| p.extension().is_some_and(|e| e != "obj" && e != "mtl"))
            .count();
        let input = files.bytes();
        let base = LIVE.load(Relaxed);
        PEAK.store(base, Relaxed);
        let start = Instant::now();
        let outcome = std::panic::catch_unwind(|| {
            let loaded = obj::load_from(Path::new(SCENE), files);
            let rendered = loaded.as_ref().ok().map(|(scene, _)| {
                let settings = RenderSettings::new(3, 2)
                    .accuracy(0.5)
                    .rays_per_record(4)
                    .light_samples(1);
                settings
                    .cache_config(scene)
                    .map(|config| {
                        let (frame, _) = render_with_scheme(
                            Scheme::Wf,
                            scene,
                            &scene.camera(),
                            &settings,
                            config,
                            1,
                        );
                        frame.image.pixels().iter().all(|p| p.is_finite())
                    })
                    .map_err(|e| e.to_string())
            });
            (loaded.map(|_| ()), rendered)
        });
        let took = start.elapsed();
        let peak = PEAK.load(Relaxed).saturating_sub(base);
        tally.cases += 1;
        tally.slowest = tally.slowest.max(took);
        tally.largest_peak = tally.largest_peak.max(peak);
        if input >= 1024 && textures == 0 {
            tally.peak_per_byte = tally.peak_per_byte.max(peak as f64 / input as f64);
        }
        tally.worst_peak_ratio = tally
            .worst_peak_ratio
            .max(peak as f64 / allowed_peak(input, textures) as f64);
        let (loaded, rendered) = outcome.map_err(|p| {
            let why = p
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| p.downcast_ref::<&str>().copied())
                .unwrap_or("(not a string)");
            format!("panicked: {why}")
        })?;
        if took > CASE_TIME {
            return Err(format!("took {took:?}, over {CASE_TIME:?}"));
        }
        if peak > allowed_peak(input, textures) {
            return Err(format!(
                "held {peak} bytes at its peak, over the bound {} for {input} bytes of input",
                allowed_peak(input, textures)
            ));
        }
        match loaded {
            Ok(()) => {
                tally.loaded += 1;
                match rendered.expect("a loaded scene is rendered") {
                    Ok(true) => tally.rendered += 1,
                    Ok(false) => return Err("rendered a pixel that is not finite".to_owned()),
                    // The settings refuse the scene (its extent): a clear refusal too.
                    Err(_) => tally.refused += 1,
                }
            }
            Err(e) => {
                tally.refused += 1;
                let text = e.to_string();
                if !text.starts_with(&e.file.display().to_string()) || e.message.is_empty() {
                    return Err(format!("an error that does not lead with its file: {text}"));
                }
                if let Some(line) = e.line {
                    match files.lines_of(&e.file) {
                        Some(n) if (1..=n).contains(&line) => {}
                        n => {
                            return Err(format!(
                                "an error names line {line} of a file of {n:?} lines: {text}"
                            ))
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// A number as an OBJ or MTL writer (or a broken one) might write it.
    fn number() -> impl Strategy<Value = String> {
        prop_oneof![
            4 => (-4.0f32..4.0).prop_map(|x| x.to_string()),
            1 => prop::sample::select(vec![
                "0", "-0", "1", "-1", "1e-45", "-1e-45", "1.17549435e-38", "1e-30", "1e15",
                "-1e15", "1e16", "1e20", "1e30", "1e38", "3.4028235e38", "-3.4028235e38",
                "3.5e38", "1e39", "nan", "NaN", "inf", "-inf", "infinity", "1e", "--1", "0x10",
                "1,5", "", ".", "+.5e-3",
            ])
            .prop_map(str::to_owned),
            1 => any::<f32>().prop_map(|x| format!("{x:e}")),
        ]
    }

    /// An index as a face corner might hold it.
    fn index() -> impl Strategy<Value = String> {
        prop_oneof![
            6 => (-6i64..12).prop_map(|i| i.to_string()),
            1 => prop::sample::select(vec![
                "0", "-0", "9223372036854775807", "-9223372036854775808", "9223372036854775808",
                "99999999999999999999", "4294967296", "-4294967297", "1.5", "x", "",
            ])
            .prop_map(str::to_owned),
        ]
    }

    fn corner() -> impl Strategy<Value = String> {
        prop_oneof![
            4 => index(),
            1 => (index(), index()).prop_map(|(a, b)| format!("{a}/{b}")),
            1 => (index(), index()).prop_map(|(a, b)| format!("{a}//{b}")),
            1 => (index(), index(), index()).prop_map(|(a, b, c)| format!("{a}/{b}/{c}")),
            1 => (index(), index(), index(), index())
                .prop_map(|(a, b, c, d)| format!("{a}/{b}/{c}/{d}")),
        ]
    }

    /// A stray word: a keyword of either format, or noise.
    fn word() -> impl Strategy<Value = String> {
        prop_oneof![
            prop::sample::select(vec![
                "v",
                "f",
                "vt",
                "vn",
                "g",
                "o",
                "s",
                "p",
                "l",
                "mtllib",
                "usemtl",
                "newmtl",
                "Kd",
                "Ke",
                "Ks",
                "map_Kd",
                "cstype",
                "curv",
                "call",
                "#",
                "\\",
                "off",
                "-o",
                "-s",
                "-mm",
                "-clamp",
                "-imfchan",
                "-type",
                "-bm",
                "m.mtl",
                "t.png",
                "scene.obj",
                "a b",
                "\t",
                "ünïcödé",
            ])
            .prop_map(str::to_owned),
            "[a-zA-Z0-9_./\\\\-]{0,12}",
        ]
    }

    fn obj_line() -> impl Strategy<Value = String> {
        prop_oneof![
            6 => prop::collection::vec(number(), 2..5).prop_map(|n| format!("v {}", n.join(" "))),
            5 => prop::collection::vec(corner(), 0..7).prop_map(|c| format!("f {}", c.join(" "))),
            1 => prop::collection::vec(number(), 1..4).prop_map(|n| format!("vt {}", n.join(" "))),
            1 => prop::collection::vec(number(), 1..4).prop_map(|n| format!("vn {}", n.join(" "))),
            1 => prop::collection::vec(library(), 0..4).prop_map(|n| format!("mtllib {}", n.join(" "))),
            1 => material_name().prop_map(|n| format!("usemtl {n}")),
            1 => prop::collection::vec(word(), 0..5).prop_map(|w| w.join(" ")),
        ]
    }

    fn library() -> impl Strategy<Value = String> {
        prop::sample::select(vec![
            "m.mtl",
            "m.mtl",
            "n.mtl",
            "scene.obj",
            "none.mtl",
            "../m.mtl",
        ])
        .prop_map(str::to_owned)
    }

    fn material_name() -> impl Strategy<Value = String> {
        prop::sample::select(vec!["light", "grey", "tex", "(null)", "", "light light"])
            .prop_map(str::to_owned)
    }

    fn mtl_line() -> impl Strategy<Value = String> {
        prop_oneof![
            2 => material_name().prop_map(|n| format!("newmtl {n}")),
            2 => prop::collection::vec(number(), 0..5).prop_map(|n| format!("Kd {}", n.join(" "))),
            2 => prop::collection::vec(number(), 0..5).prop_map(|n| format!("Ke {}", n.join(" "))),
            2 => prop::collection::vec(word(), 0..6).prop_map(|w| format!("map_Kd {}", w.join(" "))),
            1 => prop::collection::vec(word(), 0..5).prop_map(|w| w.join(" ")),
        ]
    }

    /// A valid scene: a lit, closed-ish set of quads with materials from `m.mtl`.
    fn valid_scene(quads: usize, scale: f32, offset: f32) -> Files {
        let mut obj = String::from("mtllib m.mtl\n");
        for q in 0..quads {
            let y = offset + scale * q as f32;
            for (x, z) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
                obj += &format!("v {} {y} {}\n", offset + scale * x, offset + scale * z);
            }
            let m = if q + 1 == quads { "light" } else { "grey" };
            obj += &format!("usemtl {m}\nf -4 -3 -2 -1\n");
        }
        let mtl = "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl light\nKd 0 0 0\nKe 5 5 5\n";
        let mut files = Files::default();
        files.0.insert(PathBuf::from(SCENE), obj.into_bytes());
        files
            .0
            .insert(PathBuf::from("fuzz/m.mtl"), mtl.as_bytes().to_vec());
        files
    }

    /// A PNG of `w` x `h` grey pixels.
    fn png(w: u32, h: u32) -> Vec<u8> {
        let mut out = Vec::new();
        image::RgbImage::from_pixel(w, h, image::Rgb([128, 64, 32]))
            .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
            .expect("a PNG");
        out
    }

    /// A PNG whose header claims `w` x `h` pixels and whose data is the 1 x 1 image's.
    fn png_claiming(w: u32, h: u32) -> Vec<u8> {
        let mut bytes = png(1, 1);
        // IHDR's width and height follow the 8-byte signature, the chunk's length and its type.
        bytes[16..20].copy_from_slice(&w.to_be_bytes());
        bytes[20..24].copy_from_slice(&h.to_be_bytes());
        // The CRC over the chunk's type and data (13 bytes), so the decoder reads the header.
        let crc = crc32(&bytes[12..29]);
        bytes[29..33].copy_from_slice(&crc.to_be_bytes());
        bytes
    }

    fn crc32(data: &[u8]) -> u32 {
        let mut crc = u32::MAX;
        for &b in data {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 == 1 {
                    (crc >> 1) ^ 0xEDB8_8320
                } else {
                    crc >> 1
                };
            }
        }
        !crc
    }

    fn texture() -> impl Strategy<Value = Vec<u8>> {
        prop_oneof![
            prop::collection::vec(any::<u8>(), 0..64),
            (1u32..9, 1u32..9, any::<prop::sample::Index>()).prop_map(|(w, h, at)| {
                let b = png(w, h);
                b[..at.index(b.len() + 1)].to_vec()
            }),
            (1u32..9, 1u32..9).prop_map(|(w, h)| png(w, h)),
            prop::sample::select(vec![
                (0u32, 0u32),
                (1 << 31, 1),
                (u32::MAX, u32::MAX),
                (16_384, 16_384),
                (16_385, 1),
                (100_000, 100_000),
            ])
            .prop_map(|(w, h)| png_claiming(w, h)),
        ]
    }

    /// One case: a set of files whose scene is `fuzz/scene.obj`.
    fn case() -> impl Strategy<Value = Files> {
        prop_oneof![
            // Token streams.
            4 => (
                prop::collection::vec(obj_line(), 0..40),
                prop::collection::vec(mtl_line(), 0..16),
                prop::collection::vec(mtl_line(), 0..4),
                texture(),
            )
                .prop_map(|(obj, m, n, t)| {
                    let mut files = Files::default();
                    files.0.insert(PathBuf::from(SCENE), obj.join("\n").into_bytes());
                    files.0.insert(PathBuf::from("fuzz/m.mtl"), m.join("\n").into_bytes());
                    files.0.insert(PathBuf::from("fuzz/n.mtl"), n.join("\n").into_bytes());
                    files.0.insert(PathBuf::from("fuzz/t.png"), t);
                    files
                }),
            // A valid scene cut at a random byte of one of its files.
            1 => (1usize..6, any::<prop::sample::Index>(), any::<bool>()).prop_map(|(q, at, mtl)| {
                let mut files = valid_scene(q, 1.0, 0.0);
                let name = PathBuf::from(if mtl { "fuzz/m.mtl" } else { SCENE });
                let b = files.0.get_mut(&name).expect("written");
                b.truncate(at.index(b.len() + 1));
                files
            }),
            // A valid scene with a byte that is not UTF-8 put in.
            1 => (1usize..6, any::<prop::sample::Index>(), 0x80u8..=0xFF, any::<bool>())
                .prop_map(|(q, at, byte, mtl)| {
                    let mut files = valid_scene(q, 1.0, 0.0);
                    let name = PathBuf::from(if mtl { "fuzz/m.mtl" } else { SCENE });
                    let b = files.0.get_mut(&name).expect("written");
                    b.insert(at.index(b.len() + 1), byte);
                    files
                }),
            // mtllib chains: many libraries, named again and again.
            1 => (1usize..200, 1usize..20).prop_map(|(lines, libs)| {
                let mut files = valid_scene(2, 1.0, 0.0);
                let mut obj = String::new();
                for k in 0..lines {
                    obj += &format!("mtllib l{}.mtl m.mtl scene.obj\n", k % libs);
                }
                obj += std::str::from_utf8(&files.0[Path::new(SCENE)]).expect("UTF-8");
                for l in 0..libs {
                    files.0.insert(
                        PathBuf::from(format!("fuzz/l{l}.mtl")),
                        format!("newmtl grey\nKd 0.{l} 0.5 0.5\nmap_Kd t.png\n").into_bytes(),
                    );
                }
                files.0.insert(PathBuf::from(SCENE), obj.into_bytes());
                files.0.insert(PathBuf::from("fuzz/t.png"), png(2, 2));
                files
            }),
            // Extreme but valid geometry: scale and position near either end of f32, with
            // degenerate (collapsed) and coincident quads mixed in.
            2 => (
                1usize..6,
                prop::sample::select(vec![
                    1.0f32, 1e-45, 1e-40, 1e-30, 1e-10, 1e10, 1e15, 1e18, 1e20, 1e30, 3e38, f32::MAX,
                ]),
                prop::sample::select(vec![0.0f32, -1.0, 1e15, -1e16, 1e30, f32::MAX, -f32::MAX]),
                0usize..3,
            )
                .prop_map(|(q, scale, offset, extra)| {
                    let mut files = valid_scene(q, scale, offset);
                    let mut obj = String::from_utf8(files.0[Path::new(SCENE)].clone()).expect("UTF-8");
                    for _ in 0..extra {
                        // A collapsed triangle, then the last quad again.
                        obj += "f -1 -1 -1\nf -4 -3 -2 -1\n";
                    }
                    files.0.insert(PathBuf::from(SCENE), obj.into_bytes());
                    files
                }),
        ]
    }

    /// A quad whose last side is a polygon of `n` vertices (a fan of `n - 2` triangles), under a
    /// light: the fixed cases of polygons of 10^5 vertices and more.
    fn big_polygon(n: usize) -> Files {
        let mut files = valid_scene(1, 1.0, 2.0);
        let mut obj = String::from_utf8(files.0[Path::new(SCENE)].clone()).expect("UTF-8");
        for k in 0..n {
            let t = std::f32::consts::TAU * k as f32 / n as f32;
            obj += &format!("v {} 0 {}\n", t.cos(), t.sin());
        }
        obj += "usemtl grey\nf";
        for k in 0..n {
            obj += &format!(" {}", k as i64 - n as i64);
        }
        obj.push('\n');
        files.0.insert(PathBuf::from(SCENE), obj.into_bytes());
        files
    }

    pub fn main() {
        // Only name filters are understood: `cargo test -- --list` and `--ignored` run nothing.
        let args: Vec<String> = std::env::args().skip(1).collect();
        if args.iter().any(|a| a == "--list" || a == "--ignored") {
            return;
        }
        let cases: u32 = std::env::var("WFIC_FUZZ_CASES")
            .ok()
            .map(|v| v.parse().expect("WFIC_FUZZ_CASES: a number"))
            .unwrap_or(10_000);
        let start = Instant::now();
        let mut tally = Tally::default();
        for n in [100_000, 300_000] {
            if let Err(why) = check(&big_polygon(n), &mut tally) {
                panic!("a polygon of {n} vertices: {why}");
            }
        }
        let mut runner = TestRunner::new(Config {
            cases,
            failure_persistence: None,
            ..Config::default()
        });
        let shared = std::cell::RefCell::new(tally);
        let result = runner.run(&case(), |files| {
            check(&files, &mut shared.borrow_mut()).map_err(TestCaseError::fail)
        });
        let tally = shared.into_inner();
        if let Err(e) = result {
            panic!("fuzzing the scene reader: {e}");
        }
        println!(
            "obj_fuzz: {} cases ({} random) in {:.1} s: {} loaded, {} rendered, {} refused; \
             slowest case {:.3} s; worst peak {:.3} of its bound; largest peak {} bytes; \
             at most {:.0} bytes a byte of input",
            tally.cases,
            cases,
            start.elapsed().as_secs_f64(),
            tally.loaded,
            tally.rendered,
            tally.refused,
            tally.slowest.as_secs_f64(),
            tally.worst_peak_ratio,
            tally.largest_peak,
            tally.peak_per_byte,
        );
    }
}
