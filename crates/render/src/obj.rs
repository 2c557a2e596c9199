//! Wavefront OBJ and MTL loading (plain or gzipped, `NAME.obj.gz`): positions (`v`), faces (`f`, polygons fanned into triangles,
//! negative indices allowed), materials (`mtllib`, `usemtl`; in the MTL `newmtl`, `Kd` diffuse
//! colour, `Ke` emission, and `map_Kd`'s mean colour for a material without `Kd`). Texture
//! coordinates, normals, groups, objects and smoothing are read past silently (a face's `vt` and
//! `vn` indices must still be indices). Statements that are valid but not used (free-form geometry,
//! display attributes, points and lines; specular, transparency and other textures in the MTL)
//! and statements the reader does not know are skipped with one [`ObjWarning`] per keyword and
//! file, not refused. Errors (bad numbers, bad indices, missing OBJ or MTL files) name the file
//! and the line.
//!
//! A hand-written reader rather than `tobj`: it is short, and it can say which line of which file
//! is wrong, which a user fixing an export needs.

use super::camera::{Camera, Orbit};
use super::colour::srgb_to_linear;
use super::scene::{Material, MaterialId, Scene, SceneBuilder, SceneError};
use glam::Vec3;
use std::borrow::Cow;
use std::collections::{HashMap, HashSet};
use std::fmt;
use std::path::{Path, PathBuf};

/// Why an OBJ scene could not be loaded.
#[derive(Debug)]
pub struct ObjError {
    /// The file at fault.
    pub file: PathBuf,
    /// The line at fault (1-based), when there is one.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ObjError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{line}: {}", self.file.display(), self.message),
            None => write!(f, "{}: {}", self.file.display(), self.message),
        }
    }
}

impl std::error::Error for ObjError {}

/// Something an OBJ or MTL file holds that the reader skipped or could not use: the scene loads
/// all the same.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ObjWarning {
    /// The OBJ or MTL file.
    pub file: PathBuf,
    /// The (first) line concerned, 1-based.
    pub line: usize,
    /// The statement's keyword as written (`cstype`, `Ks`, `map_Kd`, ...).
    pub statement: String,
    /// What was skipped or not used, and why.
    pub message: String,
}

impl fmt::Display for ObjWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.file.display(), self.line, self.message)
    }
}

fn err(file: &Path, line: Option<usize>, message: impl Into<String>) -> ObjError {
    ObjError {
        file: file.to_owned(),
        line,
        message: message.into(),
    }
}

/// Where the reader gets the bytes of the files it reads (the OBJ file, the MTL files it names,
/// their textures): the file system for a user's scene ([`FileSystem`]), or files compiled into
/// the binary for the built-in scenes (`scenes::Embedded`). Passing the source in keeps the
/// reader ignorant of where built-in files live.
pub trait FileResolver {
    /// The bytes of the file at `path`, or why they cannot be had.
    fn read(&self, path: &Path) -> std::io::Result<Cow<'static, [u8]>>;
}

/// The file system: where a user's OBJ, MTL and texture files are read from.
#[derive(Clone, Copy, Debug, Default)]
pub struct FileSystem;

impl FileResolver for FileSystem {
    fn read(&self, path: &Path) -> std::io::Result<Cow<'static, [u8]>> {
        std::fs::read(path).map(Cow::Owned)
    }
}

/// The text of `file` from `files`, gunzipped when its name ends in `.gz`.
fn read(file: &Path, files: &dyn FileResolver) -> Result<String, ObjError> {
    let bytes = files
        .read(file)
        .map_err(|e| err(file, None, format!("cannot read: {e}")))?;
    let bytes = if file.extension().is_some_and(|e| e == "gz") {
        let mut out = Vec::new();
        std::io::Read::read_to_end(&mut flate2::read::GzDecoder::new(&bytes[..]), &mut out)
            .map_err(|e| err(file, None, format!("cannot gunzip: {e}")))?;
        out
    } else {
        bytes.into_owned()
    };
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count();
        err(
            file,
            Some(line),
            format!("not UTF-8 text (byte {at} of the file)"),
        )
    })
}

/// `w` as a finite number, or an error naming it.
fn number(w: &str, file: &Path, line: usize) -> Result<f32, ObjError> {
    w.parse::<f32>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| err(file, Some(line), format!("`{w}` is not a finite number")))
}

fn floats<'a, const N: usize>(
    file: &Path,
    line: usize,
    what: &str,
    words: &mut impl Iterator<Item = &'a str>,
) -> Result<[f32; N], ObjError> {
    let mut out = [0.0; N];
    for (i, o) in out.iter_mut().enumerate() {
        let w = words.next().ok_or_else(|| {
            err(
                file,
                Some(line),
                format!("`{what}` needs {N} numbers, found {i}"),
            )
        })?;
        *o = number(w, file, line)?;
    }
    Ok(out)
}

/// Why a statement was skipped, in the warnings of statements the reader does not know.
const UNKNOWN: &str = "skipped: not a statement this reader knows";

/// OBJ statements that are valid but not used, by group, with the reason their warning gives.
const OBJ_UNUSED: &[(&[&str], &str)] = &[
    (
        &[
            "cstype", "deg", "bmat", "step", "curv", "curv2", "surf", "parm", "trim", "hole",
            "scrv", "sp", "end", "con", "mg", "vp",
        ],
        "skipped: free-form curves and surfaces are not rendered",
    ),
    (
        &["p", "l"],
        "skipped: points and lines have no area to render",
    ),
    (
        &[
            "bevel",
            "c_interp",
            "d_interp",
            "lod",
            "usemap",
            "maplib",
            "shadow_obj",
            "trace_obj",
            "ctech",
            "stech",
        ],
        "skipped: display and render attributes are not used",
    ),
    (
        &["call", "csh"],
        "skipped: other files are not included and commands are not run",
    ),
];

/// MTL statements that are valid but not used, as [`OBJ_UNUSED`].
const MTL_UNUSED: &[(&[&str], &str)] = &[
    (
        &[
            "Ka",
            "Ks",
            "Ns",
            "Ni",
            "d",
            "Tr",
            "Tf",
            "illum",
            "sharpness",
        ],
        "skipped: materials are diffuse (`Kd`) and emissive (`Ke`) only",
    ),
    (
        &[
            "map_Ka", "map_Ks", "map_Ns", "map_d", "map_Tr", "map_bump", "map_Bump", "bump",
            "disp", "decal", "refl", "map_refl", "map_Ke", "map_Pr", "map_Pm", "map_Ps", "norm",
        ],
        "skipped: textures other than `map_Kd` are not used",
    ),
    (
        &["Pr", "Pm", "Ps", "Pc", "Pcr", "aniso", "anisor"],
        "skipped: physically based parameters are not used",
    ),
];

/// What the warning about `map_Kd` says: the texture is not mapped, at most averaged.
const MAP_KD: &str = "textures are not mapped: a material with `Kd` keeps its `Kd`, one \
                      without takes the mean colour of its texture";

fn unused_reason(table: &[(&[&str], &'static str)], key: &str) -> Option<&'static str> {
    table
        .iter()
        .find(|(keys, _)| keys.contains(&key))
        .map(|&(_, why)| why)
}

/// The statements of one file that are skipped or only partly used: one warning per keyword,
/// at its first line, with the number of lines.
struct Skipped<'a> {
    file: &'a Path,
    /// Keyword, first line, number of lines, reason.
    seen: Vec<(String, usize, usize, &'static str)>,
}

impl<'a> Skipped<'a> {
    fn new(file: &'a Path) -> Self {
        Self {
            file,
            seen: Vec::new(),
        }
    }

    fn note(&mut self, key: &str, line: usize, why: &'static str) {
        match self.seen.iter_mut().find(|(k, ..)| k == key) {
            Some((_, _, n, _)) => *n += 1,
            None => self.seen.push((key.to_owned(), line, 1, why)),
        }
    }

    fn warn(self, out: &mut Vec<ObjWarning>) {
        for (key, line, n, why) in self.seen {
            let lines = if n == 1 { "line" } else { "lines" };
            out.push(ObjWarning {
                file: self.file.to_owned(),
                line,
                message: format!("`{key}` ({n} {lines}, the first here): {why}"),
                statement: key,
            });
        }
    }
}

/// The arguments of a texture option.
#[derive(Clone, Copy)]
enum OptionArgs {
    /// `on` or `off`.
    OnOff,
    /// This many numbers.
    Numbers(usize),
    /// One to three numbers (`-o`, `-s`, `-t`).
    UpToThree,
    /// One of `r g b m l z`.
    Channel,
    /// One word.
    Word,
}

/// The texture options of the MTL format.
const TEXTURE_OPTIONS: &[(&str, OptionArgs)] = &[
    ("-blendu", OptionArgs::OnOff),
    ("-blendv", OptionArgs::OnOff),
    ("-cc", OptionArgs::OnOff),
    ("-clamp", OptionArgs::OnOff),
    ("-bm", OptionArgs::Numbers(1)),
    ("-boost", OptionArgs::Numbers(1)),
    ("-texres", OptionArgs::Numbers(1)),
    ("-mm", OptionArgs::Numbers(2)),
    ("-o", OptionArgs::UpToThree),
    ("-s", OptionArgs::UpToThree),
    ("-t", OptionArgs::UpToThree),
    ("-imfchan", OptionArgs::Channel),
    ("-type", OptionArgs::Word),
];

/// The file name of a texture statement's arguments (`[options] file`), its options read past.
/// A bad option argument is an error; the first word that is not a known option starts the
/// file name (which may hold spaces).
fn texture_name(key: &str, words: &[&str], file: &Path, line: usize) -> Result<String, ObjError> {
    let mut at = 0;
    while let Some(&(option, args)) = words
        .get(at)
        .and_then(|w| TEXTURE_OPTIONS.iter().find(|(o, _)| o == w))
    {
        at += 1;
        let arg = |at: usize| {
            words.get(at).copied().ok_or_else(|| {
                err(
                    file,
                    Some(line),
                    format!("`{key}` option `{option}` lacks its argument"),
                )
            })
        };
        let expect = |w: &str, allowed: &[&str]| {
            if allowed.contains(&w) {
                Ok(())
            } else {
                Err(err(
                    file,
                    Some(line),
                    format!("`{option}` takes one of {}, not `{w}`", allowed.join(" ")),
                ))
            }
        };
        match args {
            OptionArgs::OnOff => expect(arg(at)?, &["on", "off"])?,
            OptionArgs::Channel => expect(arg(at)?, &["r", "g", "b", "m", "l", "z"])?,
            OptionArgs::Word => {
                arg(at)?;
            }
            OptionArgs::Numbers(n) => {
                for k in 0..n {
                    number(arg(at + k)?, file, line)?;
                }
                at += n - 1;
            }
            OptionArgs::UpToThree => {
                number(arg(at)?, file, line)?;
                // The optional two: numbers that leave a word for the file name.
                for _ in 0..2 {
                    if at + 2 < words.len() && number(words[at + 1], file, line).is_ok() {
                        at += 1;
                    } else {
                        break;
                    }
                }
            }
        }
        at += 1;
    }
    if at == words.len() {
        return Err(err(
            file,
            Some(line),
            format!("`{key}` without a file name"),
        ));
    }
    Ok(words[at..].join(" "))
}

/// The texture file `name` of an MTL file in `dir`, read from `files`: its path and its bytes.
/// Exports from Windows may separate folders with `\\`: when the name as written cannot be read,
/// it is tried with `/`.
fn read_texture(
    files: &dyn FileResolver,
    dir: &Path,
    name: &str,
) -> (PathBuf, std::io::Result<Cow<'static, [u8]>>) {
    let path = dir.join(name);
    match files.read(&path) {
        Err(_) if name.contains('\\') => {
            let other = dir.join(name.replace('\\', "/"));
            let bytes = files.read(&other);
            (other, bytes)
        }
        bytes => (path, bytes),
    }
}

/// The mean colour of the texture `bytes` read from `path`: every pixel linearised from sRGB,
/// then averaged (the mean of the linear values, not the linearised mean of the encoded ones);
/// alpha is ignored. PNG, JPEG and TGA decode (the `image` features this crate enables), told
/// apart by the name's extension or the bytes. The error says why the texture cannot be used.
fn texture_mean(path: &Path, bytes: &[u8]) -> Result<Vec3, String> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes));
    if let Ok(format) = image::ImageFormat::from_path(path) {
        reader.set_format(format);
    }
    let mut reader = reader
        .with_guessed_format()
        .map_err(|e| format!("cannot be read: {e}"))?;
    reader.limits(texture_limits());
    let image = reader
        .decode()
        .map_err(|e| format!("cannot be decoded: {e}"))?;
    let n = f64::from(image.width()) * f64::from(image.height());
    if n == 0.0 {
        return Err("has no pixels".to_owned());
    }
    let mut sum = [0.0f64; 3];
    let mut add = |rgb: [f32; 3]| {
        for (s, c) in sum.iter_mut().zip(rgb) {
            *s += f64::from(srgb_to_linear(c));
        }
    };
    // Averaged at the image's own depth: an 8-bit texture is never widened to 12 bytes a pixel.
    if image.color().bytes_per_pixel() / image.color().channel_count() == 1 {
        image
            .into_rgb8()
            .pixels()
            .for_each(|p| add(p.0.map(|c| f32::from(c) / 255.0)));
    } else {
        image.into_rgb32f().pixels().for_each(|p| add(p.0));
    }
    Ok(Vec3::from_array(sum.map(|s| (s / n) as f32)))
}

/// The largest texture side the reader decodes.
pub const MAX_TEXTURE_SIDE: u32 = 16_384;

/// The most a texture's decoding may allocate (the `image` crate's own accounting); with the
/// side bound, what keeps a small file that claims a huge image from taking the memory.
pub const MAX_TEXTURE_BYTES: u64 = 256 << 20;

fn texture_limits() -> image::Limits {
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIDE);
    limits.max_image_height = Some(MAX_TEXTURE_SIDE);
    limits.max_alloc = Some(MAX_TEXTURE_BYTES);
    limits
}

/// The material an MTL file is defining, until the next `newmtl`.
struct Pending {
    name: String,
    /// Whether it gave `Kd`.
    kd: bool,
    /// Its `map_Kd` file name and line.
    texture: Option<(String, usize)>,
}

/// Ends material `p` of MTL `file`: without `Kd` but with a `map_Kd`, it takes the texture's
/// mean colour (decoded once per file in `textures`); a texture that cannot be used is a warning
/// and leaves the default grey.
fn finish_material(
    p: Pending,
    file: &Path,
    files: &dyn FileResolver,
    out: &mut HashMap<String, Material>,
    textures: &mut HashMap<PathBuf, Option<Vec3>>,
    warnings: &mut Vec<ObjWarning>,
) {
    let Some((name, line)) = p.texture.filter(|_| !p.kd) else {
        return;
    };
    let dir = file.parent().unwrap_or(Path::new("."));
    let mean = *textures.entry(dir.join(&name)).or_insert_with(|| {
        let (path, bytes) = read_texture(files, dir, &name);
        let mean = bytes
            .map_err(|e| format!("cannot be read: {e}"))
            .and_then(|bytes| texture_mean(&path, &bytes));
        match mean {
            Ok(c) => Some(c),
            Err(why) => {
                warnings.push(ObjWarning {
                    file: file.to_owned(),
                    line,
                    statement: "map_Kd".to_owned(),
                    message: format!(
                        "texture `{}` {why}: material `{}` (and any other without `Kd` that \
                         uses it) keeps the default grey",
                        path.display(),
                        p.name
                    ),
                });
                None
            }
        }
    });
    if let Some(c) = mean {
        let m = out.get_mut(&p.name).expect("inserted at newmtl");
        m.albedo = c.min(Vec3::splat(0.95));
    }
}

/// Reads the materials of an MTL file into `out` (name -> material), adding its warnings to
/// `warnings`.
fn read_mtl(
    file: &Path,
    files: &dyn FileResolver,
    out: &mut HashMap<String, Material>,
    warnings: &mut Vec<ObjWarning>,
) -> Result<(), ObjError> {
    let text = read(file, files)?;
    let mut skipped = Skipped::new(file);
    let mut textures = HashMap::new();
    let mut current: Option<Pending> = None;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let raw = raw.split('#').next().unwrap_or("");
        let words: Vec<&str> = raw.split_whitespace().collect();
        let Some((&key, args)) = words.split_first() else {
            continue;
        };
        match key {
            "newmtl" => {
                let name = args.join(" ");
                if name.is_empty() {
                    return Err(err(file, Some(line), "`newmtl` without a name"));
                }
                if let Some(p) = current.take() {
                    finish_material(p, file, files, out, &mut textures, warnings);
                }
                out.insert(name.clone(), Material::diffuse(Vec3::splat(0.7)));
                current = Some(Pending {
                    name,
                    kd: false,
                    texture: None,
                });
            }
            "Kd" | "Ke" => {
                let p = current
                    .as_mut()
                    .ok_or_else(|| err(file, Some(line), format!("`{key}` before any `newmtl`")))?;
                let [r, g, b] = floats::<3>(file, line, key, &mut args.iter().copied())?;
                let c = Vec3::new(r, g, b);
                if c.min_element() < 0.0 {
                    return Err(err(
                        file,
                        Some(line),
                        format!("`{key}` has a negative channel"),
                    ));
                }
                let m = out.get_mut(&p.name).expect("inserted at newmtl");
                if key == "Kd" {
                    // A diffuse reflectance of 1 or more would not conserve energy.
                    m.albedo = c.min(Vec3::splat(0.95));
                    p.kd = true;
                } else {
                    m.emission = c;
                }
            }
            "map_Kd" => {
                let p = current
                    .as_mut()
                    .ok_or_else(|| err(file, Some(line), "`map_Kd` before any `newmtl`"))?;
                p.texture = Some((texture_name(key, args, file, line)?, line));
                skipped.note(key, line, MAP_KD);
            }
            _ => skipped.note(key, line, unused_reason(MTL_UNUSED, key).unwrap_or(UNKNOWN)),
        }
    }
    if let Some(p) = current.take() {
        finish_material(p, file, files, out, &mut textures, warnings);
    }
    skipped.warn(warnings);
    Ok(())
}

/// An OBJ index as written: a non-zero integer (1-based, or negative from the end).
fn index(text: &str, what: &str, word: &str, file: &Path, line: usize) -> Result<i64, ObjError> {
    match text.parse::<i64>() {
        Ok(0) => Err(err(
            file,
            Some(line),
            format!("`{word}`: {what} index 0 is not valid (OBJ indices start at 1)"),
        )),
        Ok(i) => Ok(i),
        Err(_) => Err(err(
            file,
            Some(line),
            format!("`{word}`: `{text}` is not a {what} index"),
        )),
    }
}

/// The position index of face corner `word` (`v`, `v/vt`, `v//vn` or `v/vt/vn`), checked
/// against the `count` vertices so far. Its texture coordinate and normal indices, which are not
/// used, must be indices too but are not checked against the `vt` and `vn` lines.
fn corner(word: &str, count: usize, file: &Path, line: usize) -> Result<usize, ObjError> {
    let mut parts = word.split('/');
    let i = index(parts.next().unwrap_or(""), "vertex", word, file, line)?;
    for (what, text) in ["texture coordinate", "normal"]
        .into_iter()
        .zip(parts.by_ref())
    {
        if !text.is_empty() {
            index(text, what, word, file, line)?;
        }
    }
    if parts.next().is_some() {
        return Err(err(
            file,
            Some(line),
            format!("`{word}` is not a face corner (v, v/vt, v//vn or v/vt/vn)"),
        ));
    }
    let at = if i > 0 { i - 1 } else { count as i64 + i };
    if at < 0 || at >= count as i64 {
        return Err(err(
            file,
            Some(line),
            format!("vertex index {i} is out of range ({count} vertices so far)"),
        ));
    }
    Ok(at as usize)
}

/// The triangles of a convex polygon of `n` corners, as corner triples in the polygon's
/// winding: the polygon is halved along a diagonal, and each half in turn, so most triangles are
/// small and near the boundary. A fan from one corner gives the same triangles for a triangle or
/// a quad, but for a polygon of many corners it gives long slivers that all share a corner, on
/// which the BVH builder's time grows with the square of their number
/// (docs/tried-and-dropped.md, "Fanned polygons").
fn triangulate(n: usize) -> Vec<[usize; 3]> {
    let mut out = Vec::with_capacity(n.saturating_sub(2));
    // Each range of corners `a..=b` is closed by the diagonal `a b`: its triangle takes the
    // middle corner, rounded up, and leaves the two ranges either side (left first, so a quad
    // gives the fan's (0 1 2), (0 2 3) in that order).
    // The stack holds ranges to split and triangles to emit once the range left of them is done.
    let mut stack = vec![Err((0, n.saturating_sub(1)))];
    while let Some(item) = stack.pop() {
        match item {
            Ok(triangle) => out.push(triangle),
            Err((a, b)) if b >= a + 2 => {
                let m = (a + b).div_ceil(2);
                stack.extend([Err((m, b)), Ok([a, m, b]), Err((a, m))]);
            }
            Err(_) => {}
        }
    }
    out
}

/// Reads an OBJ file (and the MTL files it names, relative to it) into a scene builder, adding
/// the warnings of both to `warnings`.
fn read_obj(
    file: &Path,
    files: &dyn FileResolver,
    warnings: &mut Vec<ObjWarning>,
) -> Result<SceneBuilder, ObjError> {
    let text = read(file, files)?;
    let dir = file.parent().unwrap_or(Path::new("."));
    let mut b = SceneBuilder::new();
    let default = b.material(Material::diffuse(Vec3::splat(0.7)));
    let mut library: HashMap<String, Material> = HashMap::new();
    let mut ids: HashMap<String, MaterialId> = HashMap::new();
    let mut current = default;
    let mut positions: Vec<Vec3> = Vec::new();
    let mut libraries: HashSet<PathBuf> = HashSet::new();
    let mut skipped = Skipped::new(file);
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let raw = raw.split('#').next().unwrap_or("");
        let mut words = raw.split_whitespace();
        let Some(key) = words.next() else { continue };
        match key {
            "v" => {
                let [x, y, z] = floats::<3>(file, line, "v", &mut words)?;
                positions.push(Vec3::new(x, y, z));
            }
            "f" => {
                let corners = words
                    .map(|w| corner(w, positions.len(), file, line))
                    .collect::<Result<Vec<_>, _>>()?;
                if corners.len() < 3 {
                    return Err(err(
                        file,
                        Some(line),
                        format!("a face needs at least 3 vertices, found {}", corners.len()),
                    ));
                }
                for [i, j, k] in triangulate(corners.len()) {
                    b.triangle(
                        positions[corners[i]],
                        positions[corners[j]],
                        positions[corners[k]],
                        current,
                    );
                }
            }
            "mtllib" => {
                let names: Vec<&str> = words.collect();
                if names.is_empty() {
                    return Err(err(file, Some(line), "`mtllib` without a file name"));
                }
                for name in names {
                    // A library named again defines the same materials again: it is read once,
                    // so a file that names one library on every line still loads in linear time.
                    if !libraries.insert(dir.join(name)) {
                        continue;
                    }
                    read_mtl(&dir.join(name), files, &mut library, warnings).map_err(|mut e| {
                        e.message = format!("{} (named by {}:{line})", e.message, file.display());
                        e
                    })?;
                }
            }
            "usemtl" => {
                let name = words.collect::<Vec<_>>().join(" ");
                current = match ids.get(&name) {
                    Some(&id) => id,
                    None => match library.get(&name) {
                        Some(&m) => {
                            let id = b.material(m);
                            ids.insert(name, id);
                            id
                        }
                        // Real exports name materials no MTL defines (`usemtl (null)`, a
                        // library left behind): render those faces grey rather than refuse.
                        None => {
                            skipped.note(
                                "usemtl",
                                line,
                                "names a material no mtllib defines: its faces use the default grey",
                            );
                            default
                        }
                    },
                };
            }
            "vt" | "vn" | "g" | "o" | "s" => {}
            _ => skipped.note(key, line, unused_reason(OBJ_UNUSED, key).unwrap_or(UNKNOWN)),
        }
    }
    skipped.warn(warnings);
    if b.triangle_count() == 0 {
        return Err(err(file, None, "no faces: the file holds no triangles"));
    }
    Ok(b)
}

/// The largest coordinate magnitude the loader accepts: far below where single precision's
/// products of two coordinate differences (the triangles' normals and areas) overflow, near
/// 1.8e19 a coordinate.
pub const MAX_COORDINATE: f32 = 1e15;

/// Prints warnings to standard error, one a line.
fn print(warnings: &[ObjWarning]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// Loads an OBJ file (and the MTL files it names, relative to it) from the file system into a
/// scene builder, printing its [`ObjWarning`]s to standard error.
pub fn load_builder(file: &Path) -> Result<SceneBuilder, ObjError> {
    load_builder_from(file, &FileSystem)
}

/// [`load_builder`], reading the OBJ file and the files it names from `files`: the built-in
/// scenes pass the resolver of the files compiled into the binary.
pub fn load_builder_from(file: &Path, files: &dyn FileResolver) -> Result<SceneBuilder, ObjError> {
    let mut warnings = Vec::new();
    let b = read_obj(file, files, &mut warnings);
    print(&warnings);
    b
}

/// Loads an OBJ scene. When no material emits, a light panel is added under the top of the
/// bounding box (30% of the horizontal extent, facing down), so scenes exported without
/// emission (Crytek's Sponza) still render; the default camera stands inside the bounds at a
/// fifth of the longer horizontal axis, looking along it. Its [`ObjWarning`]s are printed to
/// standard error; [`load_with_warnings`] returns them instead.
pub fn load(file: &Path) -> Result<Scene, ObjError> {
    let (scene, warnings) = load_with_warnings(file)?;
    print(&warnings);
    Ok(scene)
}

/// [`load`], returning the warnings (skipped statements, unusable textures) rather than printing
/// them, in the order met: an MTL file's at its `mtllib` line, the OBJ file's own at the end.
pub fn load_with_warnings(file: &Path) -> Result<(Scene, Vec<ObjWarning>), ObjError> {
    load_from(file, &FileSystem)
}

/// [`load_with_warnings`], reading the OBJ file and the files it names from `files`.
pub fn load_from(
    file: &Path,
    files: &dyn FileResolver,
) -> Result<(Scene, Vec<ObjWarning>), ObjError> {
    let mut warnings = Vec::new();
    let mut b = read_obj(file, files, &mut warnings)?;
    let (lo, hi) = b.bounds();
    let size = hi - lo;
    // The camera, the light panel and every ray offset are made from the extent, the normals
    // from products of coordinates: beyond the bound they become infinite or NaN.
    let reach = lo.abs().max(hi.abs()).max_element();
    if reach > MAX_COORDINATE {
        return Err(err(
            file,
            None,
            format!(
                "the model spans {lo} to {hi}: a coordinate beyond ±{MAX_COORDINATE:e} is too \
                 large for single-precision rendering (scale or move the model)"
            ),
        ));
    }
    let centre = (lo + hi) * 0.5;
    if !b.has_lights() {
        let m = b.material(Material::light(Vec3::splat(10.0)));
        let (hx, hz) = (size.x * 0.15, size.z * 0.15);
        let y = hi.y - 0.02 * size.y.max(1e-3);
        let (x0, x1, z0, z1) = (centre.x - hx, centre.x + hx, centre.z - hz, centre.z + hz);
        b.quad(
            Vec3::new(x0, y, z0),
            Vec3::new(x1, y, z0),
            Vec3::new(x1, y, z1),
            Vec3::new(x0, y, z1),
            m,
        );
    }
    let axis = if size.x >= size.z { Vec3::X } else { Vec3::Z };
    let reach = size.dot(axis) * 0.3;
    let eye = centre - axis * reach - Vec3::Y * size.y * 0.2;
    let camera = Camera::look_at(eye, centre + axis * reach, Vec3::Y, 60.0);
    let orbit = Orbit {
        center: centre - Vec3::Y * size.y * 0.2,
        radius: 0.2 * size.x.min(size.z),
        look_height: centre.y - size.y * 0.3,
        vfov_degrees: 65.0,
    };
    let name = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "obj".to_owned());
    let scene = b
        .build(&name, camera, orbit)
        .map_err(|e: SceneError| err(file, None, e.to_string()))?;
    Ok((scene, warnings))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh folder for one test's files.
    fn folder(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("wfic-obj-{tag}-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A unit square in the y = 0 plane, as `v` and `f` lines.
    const SQUARE: &str = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1 2 3 4\n";

    /// The message of loading `obj` (written to `name` in `dir`) as an error.
    fn load_err(dir: &Path, name: &str, obj: &str) -> String {
        std::fs::write(dir.join(name), obj).unwrap();
        load_with_warnings(&dir.join(name))
            .map(|_| ())
            .unwrap_err()
            .to_string()
    }

    /// The materials of `mtl` (written to `name` in `dir`) and its warnings.
    fn mtl(
        dir: &Path,
        name: &str,
        mtl: &str,
    ) -> Result<(HashMap<String, Material>, Vec<ObjWarning>), ObjError> {
        std::fs::write(dir.join(name), mtl).unwrap();
        let (mut out, mut warnings) = (HashMap::new(), Vec::new());
        read_mtl(&dir.join(name), &FileSystem, &mut out, &mut warnings)?;
        Ok((out, warnings))
    }

    #[test]
    fn an_undefined_material_is_a_warning_and_renders_grey() {
        let dir = folder("null-material");
        let obj = format!("usemtl (null)\n{SQUARE}usemtl ghost\nf 1 2 3\n");
        std::fs::write(dir.join("null.obj"), obj).unwrap();
        let (scene, warnings) = load_with_warnings(&dir.join("null.obj")).unwrap();
        assert_eq!(scene.triangle_count(), 5, "every face is kept");
        let usemtl: Vec<&ObjWarning> = warnings
            .iter()
            .filter(|w| w.statement == "usemtl")
            .collect();
        assert_eq!(usemtl.len(), 1, "one warning for the kind: {warnings:?}");
        assert_eq!(usemtl[0].line, 1);
        assert!(
            usemtl[0].message.contains("2 lines"),
            "{}",
            usemtl[0].message
        );
    }

    #[test]
    fn a_real_export_loads_with_one_warning_per_skipped_kind() {
        let dir = folder("export");
        let obj = format!(
            "# exported\nmtllib scene.mtl\nmaplib lib1.mpc lib2.mpc\no thing\ng walls\n\
             s 1\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 1 0\n{SQUARE}\
             usemtl wall\nusemap wood\nmg 1 0.5\nbevel on\nlod 3\nf 1/1/1 2/2/1 3/3/1\n\
             cstype bspline\ndeg 3\nvp 0.5\nvp 0.25\ncurv 0 1 1 2 3 4\nparm u 0 0 0 0 1 1 1 1\n\
             end\ncstype rat bezier\nl 1 2\np 3\nfrobnicate 7\nusemap off\n"
        );
        std::fs::write(dir.join("scene.obj"), obj).unwrap();
        std::fs::write(
            dir.join("scene.mtl"),
            "newmtl wall\nNs 10\nKa 1 1 1\nKd 0.5 0.4 0.3\nKs 0.5 0.5 0.5\nNi 1.45\nd 1\n\
             illum 2\nmap_Bump -bm 0.5 normal.png\nPr 0.5\nnewmtl glass\nKs 1 1 1\nTf 1 1 1\n",
        )
        .unwrap();
        let (scene, warnings) = load_with_warnings(&dir.join("scene.obj")).unwrap();
        // The square's two triangles, the textured one and the added light panel's two.
        assert_eq!(scene.triangle_count(), 5);
        let kinds = |file: &str| {
            let mut k: Vec<&str> = warnings
                .iter()
                .filter(|w| w.file == dir.join(file))
                .map(|w| w.statement.as_str())
                .collect();
            k.sort_unstable();
            k
        };
        let mut obj_kinds = vec![
            "bevel",
            "cstype",
            "curv",
            "deg",
            "end",
            "frobnicate",
            "l",
            "lod",
            "maplib",
            "mg",
            "p",
            "parm",
            "usemap",
            "vp",
        ];
        obj_kinds.sort_unstable();
        assert_eq!(kinds("scene.obj"), obj_kinds, "{warnings:#?}");
        let mut mtl_kinds = vec!["Ka", "Ks", "Ni", "Ns", "Pr", "Tf", "d", "illum", "map_Bump"];
        mtl_kinds.sort_unstable();
        assert_eq!(kinds("scene.mtl"), mtl_kinds, "{warnings:#?}");
        // One warning per kind, at its first line, counting its lines.
        let cstype = warnings.iter().find(|w| w.statement == "cstype").unwrap();
        assert_eq!(cstype.line, 22);
        assert!(cstype.message.contains("2 lines"), "{cstype}");
        assert!(cstype.to_string().contains("scene.obj:22:"), "{cstype}");
        let unknown = warnings
            .iter()
            .find(|w| w.statement == "frobnicate")
            .unwrap();
        assert!(unknown.message.contains("not a statement"), "{unknown}");
        let ks = warnings.iter().find(|w| w.statement == "Ks").unwrap();
        assert_eq!((ks.line, ks.message.contains("2 lines")), (5, true), "{ks}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The 2 x 2 sRGB texture the `map_Kd` tests average.
    const TEXELS: [[u8; 3]; 4] = [[255, 0, 0], [0, 128, 0], [0, 0, 64], [200, 100, 50]];

    /// The mean of [`TEXELS`] in linear light, computed here apart from the reader's code.
    fn texels_mean() -> Vec3 {
        let lin = |c: u8| {
            let s = f64::from(c) / 255.0;
            if s <= 0.04045 {
                s / 12.92
            } else {
                ((s + 0.055) / 1.055).powf(2.4)
            }
        };
        let mut m = [0.0f64; 3];
        for t in TEXELS {
            for c in 0..3 {
                m[c] += lin(t[c]) / 4.0;
            }
        }
        Vec3::from_array(m.map(|v| v as f32))
    }

    fn write_texture(path: &Path) {
        let bytes: Vec<u8> = TEXELS.concat();
        image::save_buffer(path, &bytes, 2, 2, image::ColorType::Rgb8).unwrap();
    }

    #[test]
    fn map_kd_without_kd_gives_the_linear_mean_of_the_texture() {
        let dir = folder("mapkd");
        std::fs::create_dir_all(dir.join("tex")).unwrap();
        write_texture(&dir.join("tex/wood.png"));
        let (m, warnings) = mtl(
            &dir,
            "a.mtl",
            "newmtl plain\nmap_Kd tex/wood.png\n\
             newmtl options\nmap_Kd -s 1 1 1 -o 0.5 0.5 -bm 0.2 -clamp on -mm 0 1 -t 1 tex/wood.png\n\
             newmtl windows\nmap_Kd -imfchan r tex\\wood.png\n\
             newmtl kd_first\nKd 0.2 0.3 0.4\nmap_Kd tex/wood.png\n\
             newmtl kd_last\nmap_Kd tex/missing.png\nKd 0.4 0.3 0.2\n",
        )
        .unwrap();
        let want = texels_mean();
        // The expected values, and how far the linearised mean of the encoded values would be.
        assert!(
            (want - Vec3::new(0.3944, 0.0858, 0.0208))
                .abs()
                .max_element()
                < 1e-4
        );
        assert!(
            (want - Vec3::new(0.1675, 0.0409, 0.0119))
                .abs()
                .max_element()
                > 0.2
        );
        for name in ["plain", "options", "windows"] {
            let got = m[name].albedo;
            assert!(
                (got - want).abs().max_element() < 1e-5,
                "{name}: {got} != {want}"
            );
        }
        // An explicit Kd wins, before or after the texture, which is then not even opened.
        assert_eq!(m["kd_first"].albedo, Vec3::new(0.2, 0.3, 0.4));
        assert_eq!(m["kd_last"].albedo, Vec3::new(0.4, 0.3, 0.2));
        assert!(
            warnings.iter().all(|w| !w.message.contains("missing.png")),
            "{warnings:#?}"
        );
        // One note that textures are not mapped.
        let notes: Vec<_> = warnings
            .iter()
            .filter(|w| w.statement == "map_Kd")
            .collect();
        assert_eq!(notes.len(), 1, "{warnings:#?}");
        assert!(notes[0].message.contains("5 lines"), "{}", notes[0]);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn jpeg_and_tga_textures_decode_too() {
        let dir = folder("formats");
        let tga = dir.join("t.tga");
        image::save_buffer(&tga, &TEXELS.concat(), 2, 2, image::ColorType::Rgb8).unwrap();
        let got = texture_mean(&tga, &std::fs::read(&tga).unwrap()).unwrap();
        assert!((got - texels_mean()).abs().max_element() < 1e-5, "{got}");
        // A uniform JPEG (lossy, so only near its colour).
        let jpg = dir.join("u.jpg");
        let bytes: Vec<u8> = [200u8, 100, 50].repeat(64);
        image::save_buffer(&jpg, &bytes, 8, 8, image::ColorType::Rgb8).unwrap();
        let got = texture_mean(&jpg, &std::fs::read(&jpg).unwrap()).unwrap();
        let want = Vec3::from_array([200u8, 100, 50].map(|c| srgb_to_linear(f32::from(c) / 255.0)));
        assert!((got - want).abs().max_element() < 0.02, "{got} != {want}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_texture_that_cannot_be_used_is_a_warning_and_leaves_grey() {
        let dir = folder("notex");
        std::fs::write(dir.join("junk.png"), b"not a png at all").unwrap();
        let (m, warnings) = mtl(
            &dir,
            "b.mtl",
            "newmtl gone\nmap_Kd gone.png\nnewmtl also_gone\nmap_Kd gone.png\n\
             newmtl junk\nmap_Kd junk.png\nKe 1 1 1\n",
        )
        .unwrap();
        for name in ["gone", "also_gone", "junk"] {
            assert_eq!(m[name].albedo, Vec3::splat(0.7), "{name}");
        }
        assert_eq!(m["junk"].emission, Vec3::ONE);
        let texture_warnings: Vec<String> = warnings
            .iter()
            .filter(|w| w.message.starts_with("texture"))
            .map(|w| w.to_string())
            .collect();
        // One per file, not per material.
        assert_eq!(texture_warnings.len(), 2, "{texture_warnings:#?}");
        assert!(
            texture_warnings[0].contains("b.mtl:2:")
                && texture_warnings[0].contains("gone.png")
                && texture_warnings[0].contains("cannot be read"),
            "{}",
            texture_warnings[0]
        );
        assert!(
            texture_warnings[1].contains("b.mtl:6:")
                && texture_warnings[1].contains("junk.png")
                && texture_warnings[1].contains("cannot be decoded"),
            "{}",
            texture_warnings[1]
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn bad_texture_statements_are_errors_with_their_line() {
        let dir = folder("badmap");
        for (name, text, needle) in [
            ("bm.mtl", "newmtl a\nmap_Kd -bm x t.png\n", "`x`"),
            (
                "s.mtl",
                "newmtl a\nmap_Kd -s t.png\n",
                "`t.png` is not a finite",
            ),
            (
                "clamp.mtl",
                "newmtl a\nmap_Kd -clamp maybe t.png\n",
                "maybe",
            ),
            (
                "nofile.mtl",
                "newmtl a\nmap_Kd -o 1\n",
                "without a file name",
            ),
            ("empty.mtl", "newmtl a\nmap_Kd\n", "without a file name"),
            (
                "lacks.mtl",
                "newmtl a\nmap_Kd -mm 1\n",
                "lacks its argument",
            ),
            ("kd.mtl", "newmtl a\nKd 0.5 nan 0.5\n", "`nan`"),
        ] {
            let e = mtl(&dir, name, text).unwrap_err().to_string();
            assert!(
                e.contains(&format!("{name}:2:")) && e.contains(needle),
                "{name}: {e}"
            );
        }
        let e = mtl(&dir, "early.mtl", "map_Kd t.png\n").unwrap_err();
        assert!(e.to_string().contains("early.mtl:1:"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn texture_names_skip_the_options() {
        let p = Path::new("x.mtl");
        let name = |line: &str| {
            let words: Vec<&str> = line.split_whitespace().collect();
            texture_name("map_Kd", &words, p, 1).unwrap()
        };
        assert_eq!(name("a.png"), "a.png");
        assert_eq!(name("-s 2 a.png"), "a.png");
        assert_eq!(
            name("-s 1 1 1 2"),
            "2",
            "a number left last is the file name"
        );
        assert_eq!(
            name("-o 1 2 -t 0.1 0.2 0.3 -type sphere my tex.jpg"),
            "my tex.jpg"
        );
        assert_eq!(
            name("-blendu off -blendv on -cc off -texres 512 b.tga"),
            "b.tga"
        );
        assert_eq!(name("-unknown c.png"), "-unknown c.png");
    }

    /// Files in memory that count how often each is read.
    #[derive(Default)]
    struct Counted {
        files: HashMap<PathBuf, Vec<u8>>,
        reads: std::cell::RefCell<HashMap<PathBuf, usize>>,
    }

    impl FileResolver for Counted {
        fn read(&self, path: &Path) -> std::io::Result<Cow<'static, [u8]>> {
            *self.reads.borrow_mut().entry(path.to_owned()).or_default() += 1;
            self.files
                .get(path)
                .cloned()
                .map(Cow::Owned)
                .ok_or_else(|| std::io::ErrorKind::NotFound.into())
        }
    }

    #[test]
    fn a_library_named_on_every_line_is_read_once() {
        let mut obj = String::new();
        for _ in 0..1000 {
            obj += "mtllib m.mtl n.mtl\n";
        }
        obj += "usemtl light\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\n";
        let mut files = Counted::default();
        files.files.insert("d/s.obj".into(), obj.into_bytes());
        files.files.insert(
            "d/m.mtl".into(),
            b"newmtl light\nKe 1 1 1\nKs 1 1 1\n".to_vec(),
        );
        files
            .files
            .insert("d/n.mtl".into(), b"newmtl grey\nKd 0.5 0.5 0.5\n".to_vec());
        let mut warnings = Vec::new();
        let b = read_obj(Path::new("d/s.obj"), &files, &mut warnings).unwrap();
        assert!(b.has_lights());
        let reads = files.reads.borrow();
        assert_eq!(reads[Path::new("d/m.mtl")], 1, "{reads:?}");
        assert_eq!(reads[Path::new("d/n.mtl")], 1, "{reads:?}");
        // Its warnings once too: the one `Ks` line.
        assert_eq!(warnings.len(), 1, "{warnings:?}");
    }

    #[test]
    fn text_that_is_not_utf8_names_its_line() {
        let mut files = Counted::default();
        files
            .files
            .insert("d/s.obj".into(), b"v 0 0 0\nv 1 0 0\n# caf\xe9\n".to_vec());
        let e = read_obj(Path::new("d/s.obj"), &files, &mut Vec::new())
            .map(|_| ())
            .unwrap_err();
        assert_eq!(e.line, Some(3), "{e}");
        assert!(e.to_string().contains("not UTF-8"), "{e}");
    }

    #[test]
    fn polygons_are_halved_into_triangles_that_cover_them_once() {
        assert_eq!(triangulate(3), [[0, 1, 2]]);
        // A quad: the fan's two triangles, in the fan's order.
        assert_eq!(triangulate(4), [[0, 1, 2], [0, 2, 3]]);
        for n in [5, 6, 7, 64, 1000, 100_001] {
            let tris = triangulate(n);
            assert_eq!(tris.len(), n - 2, "{n} corners");
            // The triangles of a regular n-gon are in its winding (positive area) and their
            // areas add up to the polygon's: they cover it once.
            let corner = |k: usize| {
                let t = std::f64::consts::TAU * k as f64 / n as f64;
                (t.cos(), t.sin())
            };
            let mut sum = 0.0;
            for &[i, j, k] in &tris {
                assert!(i < j && j < k && k < n, "{n}: {i} {j} {k}");
                let ((ax, ay), (bx, by), (cx, cy)) = (corner(i), corner(j), corner(k));
                let area = 0.5 * ((bx - ax) * (cy - ay) - (cx - ax) * (by - ay));
                assert!(area > 0.0, "{n}: {i} {j} {k}");
                sum += area;
            }
            let polygon = 0.5 * n as f64 * (std::f64::consts::TAU / n as f64).sin();
            assert!(
                (sum - polygon).abs() < 1e-9 * polygon.max(1.0),
                "{n}: {sum} {polygon}"
            );
            // Halving keeps most triangles small: no corner is in more than ~2 log2 n of them
            // (a fan puts corner 0 in all of them).
            let mut uses = vec![0usize; n];
            tris.iter().flatten().for_each(|&c| uses[c] += 1);
            let most = *uses.iter().max().unwrap();
            assert!(
                most <= 2 * (n as f64).log2().ceil() as usize + 2,
                "{n}: {most}"
            );
        }
    }

    #[test]
    fn bad_obj_input_is_an_error_naming_file_and_line() {
        let dir = folder("badobj");
        let missing = load_with_warnings(&dir.join("nothere.obj"))
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            missing.contains("nothere.obj") && missing.contains("cannot read"),
            "{missing}"
        );
        for (name, text, needle) in [
            (
                "num.obj",
                "v 0 0 0\nv 1 0 1e99\n",
                "`1e99` is not a finite number",
            ),
            ("few.obj", "v 0 0 0\nv 1 0\n", "needs 3 numbers"),
            (
                "zero.obj",
                "v 0 0 0\nf 1 0 1\n",
                "vertex index 0 is not valid",
            ),
            (
                "range.obj",
                "v 0 0 0\nf 1 1 4\n",
                "vertex index 4 is out of range",
            ),
            (
                "neg.obj",
                "v 0 0 0\nf 1 1 -2\n",
                "vertex index -2 is out of range",
            ),
            (
                "word.obj",
                "v 0 0 0\nf 1 1 one\n",
                "`one` is not a vertex index",
            ),
            (
                "vt.obj",
                "v 0 0 0\nf 1/0 1 1\n",
                "texture coordinate index 0 is not",
            ),
            (
                "vn.obj",
                "v 0 0 0\nf 1//1.5 1 1\n",
                "`1.5` is not a normal index",
            ),
            (
                "vtnum.obj",
                "v 0 0 0\nf 1/x 1 1\n",
                "`x` is not a texture coordinate",
            ),
            ("parts.obj", "v 0 0 0\nf 1/1/1/1 1 1\n", "not a face corner"),
            ("face.obj", "v 0 0 0\nf 1 1\n", "at least 3 vertices"),
        ] {
            let e = load_err(&dir, name, text);
            assert!(
                e.contains(&format!("{name}:2:")) && e.contains(needle),
                "{name}: {e}"
            );
        }
        // A missing MTL names itself and the OBJ line that named it.
        let e = load_err(&dir, "mtl.obj", "v 0 0 0\nmtllib none.mtl\n");
        assert!(
            e.contains("none.mtl: cannot read")
                && e.contains("(named by")
                && e.contains("mtl.obj:2"),
            "{e}"
        );
        // An error in an MTL names the MTL's line.
        std::fs::write(dir.join("bad.mtl"), "newmtl a\n\nKe 1 -1 1\n").unwrap();
        let e = load_err(&dir, "badmtl.obj", &format!("mtllib bad.mtl\n{SQUARE}"));
        assert!(
            e.contains("bad.mtl:3:") && e.contains("negative") && e.contains("badmtl.obj:1"),
            "{e}"
        );
        // Geometry that is only skipped is no scene.
        let e = load_err(&dir, "curves.obj", "v 0 0 0\ncstype bspline\ncurv 0 1 1\n");
        assert!(e.contains("curves.obj") && e.contains("no faces"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn the_mean_texture_colour_reaches_the_scene() {
        let dir = folder("scene");
        write_texture(&dir.join("t.png"));
        std::fs::write(dir.join("m.mtl"), "newmtl t\nmap_Kd t.png\n").unwrap();
        std::fs::write(
            dir.join("m.obj"),
            format!("mtllib m.mtl\nusemtl t\n{SQUARE}"),
        )
        .unwrap();
        let (scene, _) = load_with_warnings(&dir.join("m.obj")).unwrap();
        let want = texels_mean();
        assert!(
            scene
                .materials()
                .iter()
                .any(|m| (m.albedo - want).abs().max_element() < 1e-5),
            "{:?}",
            scene.materials()
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
