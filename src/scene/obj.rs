//! Wavefront OBJ/MTL loading with `tobj`, plus our own checks so that bad files give
//! messages with a file and line number instead of tobj's bare error kinds (or, for some
//! malformed MTL lines, a panic inside tobj).
//!
//! Before handing the text to tobj, [`load_obj`] scans it line by line and rejects what tobj
//! would reject (or silently mis-read): unparsable numbers, NaN/infinite coordinates, face
//! indices out of range, empty `usemtl`/`mtllib`. MTL files get the same treatment. After
//! loading, all models of the OBJ are concatenated into one [`Mesh`], normals are
//! normalised (unusable ones become zero), and degenerate triangles are dropped.

use super::asset_path::{parent_dir, resolve_asset_from};
use super::{GlossyLobe, Material, Mesh};
use crate::{Error, Result};
use glam::{DVec3, Vec2, Vec3};
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Name of the material given to faces that have no `usemtl` (or name an unknown material).
pub const DEFAULT_MATERIAL_NAME: &str = "__default";
/// Albedo of [`DEFAULT_MATERIAL_NAME`], and of MTL materials without `Kd` or `map_Kd`.
pub const DEFAULT_ALBEDO: f32 = 0.8;

/// A triangle whose area is at most this fraction of the squared bounding-box diagonal is
/// degenerate: it cannot be hit reliably and has no usable geometric normal.
const DEGENERATE_AREA_FRACTION: f64 = 1e-12;

/// A material read from an MTL file (or the default material), before it is placed in a scene.
#[derive(Clone, Debug)]
pub struct ObjMaterial {
    /// Name, albedo and emission. `albedo_texture` is always `None` here: the scene loader
    /// loads [`Self::texture`] and fills it in.
    pub material: Material,
    /// The resolved `map_Kd` file, if any.
    pub texture: Option<PathBuf>,
    /// The MTL file that defined the material (`None` for [`DEFAULT_MATERIAL_NAME`]).
    /// Materials with the same name from the same library are one material.
    pub library: Option<PathBuf>,
}

/// Counts gathered while loading one OBJ file (for logs and tests).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ObjStats {
    /// Triangles after triangulation, before degenerate ones were dropped.
    pub triangles_read: usize,
    /// Triangles dropped as degenerate (repeated vertex or area near zero).
    pub degenerate_dropped: usize,
    /// Vertices whose normal in the file was unusable (zero length or not finite).
    pub unusable_normals: usize,
    /// Vertices that had no normal in the file at all.
    pub missing_normals: usize,
    /// Faces with fewer than three vertices (ignored).
    pub short_faces_ignored: usize,
}

/// One loaded OBJ file.
#[derive(Clone, Debug)]
pub struct ObjData {
    /// All models of the file concatenated. `material_ids` index into [`Self::materials`].
    pub mesh: Mesh,
    /// The materials of all `mtllib`s of the file, in file order, then the default material
    /// if some face needed it.
    pub materials: Vec<ObjMaterial>,
    /// Counts of what was read, fixed up and dropped.
    pub stats: ObjStats,
}

/// Loads an OBJ file (and the MTL files it names) into one mesh.
///
/// * Faces are triangulated (fans); points and two-vertex lines are ignored, polylines too.
/// * Faces without a material get [`DEFAULT_MATERIAL_NAME`] (grey, albedo 0.8).
/// * MTL `Kd` becomes the albedo (clamped to [0, 1]), `Ke` the emission, `map_Kd` the albedo
///   texture, resolved next to the MTL file, then along `RADSPLAT_ASSET_PATH`.
/// * Normals are normalised; unusable ones (zero length, not finite) and missing ones become
///   zero, meaning "use the geometric normal". Missing texture coordinates become zero.
/// * Degenerate triangles are dropped with a warning.
///
/// Errors name the OBJ or MTL file and the line: unreadable files, malformed lines,
/// NaN/infinite coordinates, indices out of range, a missing MTL or texture file.
pub fn load_obj(path: &Path) -> Result<ObjData> {
    let text = read_text(path)?;
    let scan = scan_obj(path, &text)?;
    // tobj triangulates polylines with three or more vertices (only two-vertex lines are
    // ignored by `ignore_lines`), which would add bogus triangles: blank those lines out,
    // keeping the line count so tobj's view of the file stays line-aligned with ours.
    let text = if scan.has_polylines {
        blank_polylines(&text)
    } else {
        text
    };

    let obj_dir = parent_dir(path);
    let libraries: RefCell<Vec<MtlLibrary>> = RefCell::new(Vec::new());
    let mtl_error: RefCell<Option<Error>> = RefCell::new(None);
    let load_library = |name: &Path| -> tobj::MTLLoadResult {
        // tobj reports a failed MTL only when no other MTL loaded, so we keep the error
        // ourselves and fail the whole OBJ on it.
        if mtl_error.borrow().is_some() {
            return Err(tobj::LoadError::GenericFailure);
        }
        match load_mtl_library(path, obj_dir, name, &scan.mtllibs) {
            Ok((library, loaded)) => {
                libraries.borrow_mut().push(library);
                loaded
            }
            Err(e) => {
                *mtl_error.borrow_mut() = Some(e);
                Err(tobj::LoadError::GenericFailure)
            }
        }
    };
    // GPU_LOAD_OPTIONS is: single_index, triangulate, ignore_points, ignore_lines.
    let loaded = tobj::load_obj_buf(&mut text.as_bytes(), &tobj::GPU_LOAD_OPTIONS, load_library);
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    let (models, tobj_materials) =
        loaded.map_err(|e| Error::invalid(path, "OBJ data", format!("cannot parse OBJ: {e}")))?;
    let tobj_materials = tobj_materials
        .map_err(|e| Error::invalid(path, "mtllib", format!("cannot load materials: {e}")))?;

    let libraries = libraries.into_inner();
    let materials = convert_materials(&tobj_materials, &libraries)?;
    for (line, name) in &scan.usemtls {
        if !materials.iter().any(|m| m.material.name == *name) {
            // Libraries that define nothing at all while the OBJ uses materials are the
            // wrong file (or an empty one): its faces would all silently turn grey.
            if let Some(empty) = libraries.first().filter(|_| materials.is_empty()) {
                let all: Vec<String> = libraries
                    .iter()
                    .map(|l| l.path.display().to_string())
                    .collect();
                return Err(Error::invalid(
                    &empty.path,
                    "MTL data",
                    format!(
                        "defines no materials (no 'newmtl' statement), but {} line {line} \
                         uses material '{name}' (material libraries: {})",
                        path.display(),
                        all.join(", ")
                    ),
                ));
            }
            log::warn!(
                "{}: line {line}: no MTL defines material '{name}'; its faces get '{}'",
                path.display(),
                DEFAULT_MATERIAL_NAME
            );
        }
    }
    let mut data = assemble_mesh(path, models, materials)?;
    data.stats.short_faces_ignored = scan.short_faces;
    if scan.short_faces > 0 {
        log::warn!(
            "{}: ignored {} faces with fewer than 3 vertices",
            path.display(),
            scan.short_faces
        );
    }
    Ok(data)
}

/// Reads a text file. Invalid UTF-8 (e.g. Latin-1 in comments of old exporters) is replaced
/// rather than rejected: only ASCII matters in OBJ/MTL syntax. A leading byte-order mark is
/// dropped. A file that is not text at all (control bytes outside comments, or a statement
/// keyword that is not ASCII: a binary file, or the wrong file) is an error naming the first
/// such line, since tobj would silently ignore every line of it.
fn read_text(path: &Path) -> Result<String> {
    let bytes = crate::input::read(path, crate::input::MAX_DATA_BYTES)?;
    let mut text = match String::from_utf8(bytes) {
        Ok(text) => text,
        Err(e) => String::from_utf8_lossy(e.as_bytes()).into_owned(),
    };
    if text.starts_with('\u{feff}') {
        text.drain(..'\u{feff}'.len_utf8());
    }
    check_text(path, &text)?;
    Ok(text)
}

/// Errors at the first line of `text` that no OBJ or MTL writer produces: a control
/// character (other than tab, carriage return, vertical tab, form feed and the DOS end-of-file
/// mark) before any `#`
/// comment, or a first word (the statement keyword) with a character that is not printable
/// ASCII. Comments may hold anything but line breaks.
fn check_text(path: &Path, text: &str) -> Result<()> {
    // Pieces of lines on every core; the first error in file order is the one returned.
    let pieces = line_pieces(text);
    crate::parallel::ordered_map(pieces.len(), |i| {
        check_lines(path, pieces[i].first_line, pieces[i].text)
    })
    .into_iter()
    .collect()
}

/// [`check_text`] of the lines of one piece, the first of them line `first_line + 1`.
fn check_lines(path: &Path, first_line: usize, text: &str) -> Result<()> {
    for (index, line) in text.split('\n').enumerate() {
        let content = line.split_once('#').map_or(line, |(before, _)| before);
        let err = |message: String| {
            Error::invalid(
                path,
                format!("line {}", first_line + index + 1),
                format!("{message}: this is not an OBJ/MTL text file"),
            )
        };
        if let Some(c) = content
            .chars()
            .find(|c| c.is_control() && !matches!(c, '\t' | '\r' | '\x0b' | '\x0c' | '\x1a'))
        {
            return Err(err(format!("control character U+{:04X}", u32::from(c))));
        }
        if let Some(keyword) = content.split_whitespace().next() {
            if !keyword.chars().all(|c| c.is_ascii_graphic()) {
                let shown: String = keyword.chars().take(16).collect();
                return Err(err(format!(
                    "statement '{}' is not a keyword (not printable ASCII{})",
                    shown.escape_debug(),
                    if keyword.contains('\u{fffd}') {
                        "; the file is not valid UTF-8 there"
                    } else {
                        ""
                    }
                )));
            }
        }
    }
    Ok(())
}

/// A run of whole lines of a text, for the checks that run on every core.
#[derive(Clone, Copy)]
struct LinePiece<'a> {
    /// Index of the piece's first line in the text (0-based).
    first_line: usize,
    /// The lines, each with its line end (the last one's may lack it).
    text: &'a str,
}

/// `text` cut after line ends into a few pieces per core (one piece for a short text).
fn line_pieces(text: &str) -> Vec<LinePiece<'_>> {
    const MIN_PIECE: usize = 1 << 16;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let parts = (text.len() / MIN_PIECE).clamp(1, 4 * cores);
    let bytes = text.as_bytes();
    let mut pieces = Vec::with_capacity(parts);
    let (mut start, mut first_line) = (0, 0);
    for k in 1..=parts {
        let mut end = (text.len() * k / parts).max(start);
        if k < parts {
            // Just after the next line end (always a character boundary).
            end = bytes[end..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(text.len(), |i| end + i + 1);
        } else {
            end = text.len();
        }
        if end > start {
            let piece = &text[start..end];
            pieces.push(LinePiece {
                first_line,
                text: piece,
            });
            first_line += piece.bytes().filter(|&b| b == b'\n').count();
            start = end;
        }
    }
    pieces
}

/// What the pre-scan of an OBJ file learned.
#[derive(Debug)]
struct ObjScan {
    /// `(line number, name)` of each `mtllib` line, to name the line if the MTL is missing.
    mtllibs: Vec<(usize, String)>,
    /// `(line number, name)` of the first `usemtl` of each material name.
    usemtls: Vec<(usize, String)>,
    /// `f` lines with one or two vertices (tobj turns them into points/lines, which we ignore).
    short_faces: usize,
    /// Whether there are `l` lines with three or more vertices.
    has_polylines: bool,
}

/// Counts of `v`, `vt`, `vn` lines of a whole file: positive face indices may refer forward
/// (tobj resolves them at the end of each object), so they are checked against these.
#[derive(Clone, Copy, Default)]
struct ElementCounts {
    positions: usize,
    texcoords: usize,
    normals: usize,
}

impl ElementCounts {
    fn count_line(&mut self, line: &str) {
        match line.split_whitespace().next() {
            Some("v") => self.positions += 1,
            Some("vt") => self.texcoords += 1,
            Some("vn") => self.normals += 1,
            _ => {}
        }
    }
}

/// Checks every line tobj interprets, mirroring its parser (see `parse_obj_line` in tobj
/// 4.0), so that every error tobj could raise is reported here first, with a line number.
fn scan_obj(path: &Path, text: &str) -> Result<ObjScan> {
    // On every core, a piece of lines each: first the element counts (face indices are
    // checked against the whole file's and against those before their line), then the
    // checks, each piece starting from the counts of the pieces before it; the results
    // merge in file order, so the first error and the first line of each name are those
    // of one pass over the file.
    let pieces = line_pieces(text);
    let counts = crate::parallel::ordered_map(pieces.len(), |i| {
        let mut c = ElementCounts::default();
        for line in pieces[i].text.lines() {
            c.count_line(line);
        }
        c
    });
    let mut totals = ElementCounts::default();
    let mut before = Vec::with_capacity(counts.len());
    for c in &counts {
        before.push(totals);
        totals.positions += c.positions;
        totals.texcoords += c.texcoords;
        totals.normals += c.normals;
    }
    let parts = crate::parallel::ordered_map(pieces.len(), |i| {
        scan_lines(path, pieces[i], before[i], &totals)
    });
    let mut scan = ObjScan {
        mtllibs: Vec::new(),
        usemtls: Vec::new(),
        short_faces: 0,
        has_polylines: false,
    };
    for part in parts {
        let part = part?;
        for (list, names) in [
            (&mut scan.mtllibs, part.mtllibs),
            (&mut scan.usemtls, part.usemtls),
        ] {
            for (line, name) in names {
                if !list.iter().any(|(_, n)| *n == name) {
                    list.push((line, name));
                }
            }
        }
        scan.short_faces += part.short_faces;
        scan.has_polylines |= part.has_polylines;
    }
    Ok(scan)
}

/// [`scan_obj`]'s checks over one piece of lines, `seen` the elements of the lines before.
fn scan_lines(
    path: &Path,
    piece: LinePiece<'_>,
    mut seen: ElementCounts,
    totals: &ElementCounts,
) -> Result<ObjScan> {
    let mut scan = ObjScan {
        mtllibs: Vec::new(),
        usemtls: Vec::new(),
        short_faces: 0,
        has_polylines: false,
    };
    let mut args: Vec<&str> = Vec::new();
    for (index, line) in piece.text.lines().enumerate() {
        let line_no = piece.first_line + index + 1;
        let err = |message: String| Error::invalid(path, format!("line {line_no}"), message);
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        args.clear();
        args.extend(words);
        match keyword {
            "v" => {
                check_position(&args).map_err(err)?;
                seen.positions += 1;
            }
            "vt" => {
                check_floats::<2>(&args, "texture coordinate (u v)").map_err(err)?;
                seen.texcoords += 1;
            }
            "vn" => {
                check_floats::<3>(&args, "normal (x y z)").map_err(err)?;
                seen.normals += 1;
            }
            "f" | "l" => {
                if args.is_empty() {
                    return Err(err(format!("'{keyword}' without vertices")));
                }
                for vertex in &args {
                    check_face_vertex(vertex, &seen, totals).map_err(err)?;
                }
                match (keyword, args.len()) {
                    ("f", 1 | 2) => scan.short_faces += 1,
                    ("l", 3..) => scan.has_polylines = true,
                    _ => {}
                }
            }
            "mtllib" | "usemtl" => {
                // Same extraction as tobj: everything after the first space (names may
                // contain spaces).
                let name = line.split_once(' ').map_or("", |(_, rest)| rest.trim());
                if name.is_empty() {
                    return Err(err(format!(
                        "'{keyword}' without a name (expected '{keyword} <name>')"
                    )));
                }
                let list = if keyword == "mtllib" {
                    &mut scan.mtllibs
                } else {
                    &mut scan.usemtls
                };
                if !list.iter().any(|(_, n)| n == name) {
                    list.push((line_no, name.to_string()));
                }
            }
            _ => {}
        }
    }
    Ok(scan)
}

/// A `v` line: `x y z`, optionally `w` (not zero) or `r g b`; the position must be finite.
fn check_position(args: &[&str]) -> std::result::Result<(), String> {
    let xyz = parse_floats::<3>(args).ok_or_else(|| {
        format!(
            "expected 3 numbers after 'v' (x y z), got '{}'",
            args.join(" ")
        )
    })?;
    let mut position = Vec3::from_array(xyz);
    match args.len() {
        3 | 6 => {}
        4 => {
            let w: f32 = args[3]
                .parse()
                .map_err(|_| format!("vertex weight w '{}' is not a number", args[3]))?;
            if w == 0.0 {
                return Err("vertex weight w is zero".to_string());
            }
            position /= w;
        }
        n => {
            return Err(format!(
                "'v' takes 3, 4 (x y z w) or 6 (x y z r g b) numbers, got {n}"
            ));
        }
    }
    if !position.is_finite() {
        return Err(format!(
            "vertex position is not finite (NaN or infinity): '{}'",
            args.join(" ")
        ));
    }
    if position.abs().max_element() > super::limits::MAX_COORDINATE {
        return Err(format!(
            "vertex position '{}' is beyond +-{:e}: a triangle's normal overflows f32 there \
             (rescale the model)",
            args.join(" "),
            super::limits::MAX_COORDINATE
        ));
    }
    Ok(())
}

/// `vt`/`vn` lines: the first `N` values must be finite numbers (tobj ignores the rest).
fn check_floats<const N: usize>(args: &[&str], what: &str) -> std::result::Result<(), String> {
    let values = parse_floats::<N>(args).ok_or_else(|| {
        format!(
            "expected {N} numbers for a {what}, got '{}'",
            args.join(" ")
        )
    })?;
    if values.iter().any(|v| !v.is_finite()) {
        return Err(format!(
            "{what} is not finite (NaN or infinity): '{}'",
            args.join(" ")
        ));
    }
    Ok(())
}

/// The first `N` words as `f32` (Rust's parser, the one tobj uses: it accepts "nan", "inf").
fn parse_floats<const N: usize>(args: &[&str]) -> Option<[f32; N]> {
    let mut values = [0.0; N];
    for (value, word) in values.iter_mut().zip(args.get(..N)?) {
        *value = word.parse().ok()?;
    }
    Some(values)
}

/// One face vertex `v`, `v/vt`, `v//vn` or `v/vt/vn`: 1-based indices, or negative ones
/// counting back from the elements read so far.
fn check_face_vertex(
    word: &str,
    seen: &ElementCounts,
    totals: &ElementCounts,
) -> std::result::Result<(), String> {
    let parts: Vec<&str> = word.split('/').collect();
    if parts.len() > 3 {
        return Err(format!(
            "face vertex '{word}' has more than 3 parts (v/vt/vn)"
        ));
    }
    let kinds = [
        ("vertex", "v", seen.positions, totals.positions),
        ("texture coordinate", "vt", seen.texcoords, totals.texcoords),
        ("normal", "vn", seen.normals, totals.normals),
    ];
    for (part, (what, keyword, seen, total)) in parts.iter().zip(kinds) {
        if part.is_empty() {
            if keyword == "v" {
                return Err(format!("face vertex '{word}' has no vertex index"));
            }
            continue;
        }
        let index: isize = part
            .parse()
            .map_err(|_| format!("face vertex '{word}': '{part}' is not an index"))?;
        let in_range = match index {
            0 => false,
            i if i > 0 => i.unsigned_abs() <= total,
            i => i.unsigned_abs() <= seen,
        };
        if !in_range {
            let available = if index < 0 { seen } else { total };
            let hint = if index == 0 {
                " (OBJ indices start at 1)"
            } else {
                ""
            };
            return Err(format!(
                "face vertex '{word}' refers to {what} {index}, \
                 but there are {available} '{keyword}' lines{hint}"
            ));
        }
    }
    Ok(())
}

/// Replaces `l` lines that have three or more vertices by empty lines.
fn blank_polylines(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut words = line.split_whitespace();
        let is_polyline = words.next() == Some("l") && words.count() >= 3;
        if !is_polyline {
            out.push_str(line);
        }
        out.push('\n');
    }
    out
}

/// An MTL file that was loaded for the OBJ.
struct MtlLibrary {
    path: PathBuf,
    /// How many materials tobj got from it (they are appended in library order).
    count: usize,
    /// Line number of the `map_Kd` of each material, for error messages.
    map_kd_lines: HashMap<String, usize>,
}

/// Finds, checks and parses one `mtllib` of `obj_path`. The second value is what tobj's
/// material loader callback returns (always `Ok`).
fn load_mtl_library(
    obj_path: &Path,
    obj_dir: &Path,
    name: &Path,
    mtllibs: &[(usize, String)],
) -> Result<(MtlLibrary, tobj::MTLLoadResult)> {
    let name = name.to_string_lossy();
    let field = match mtllibs.iter().find(|(_, n)| *n == name) {
        Some((line, _)) => format!("line {line}, mtllib"),
        None => "mtllib".to_string(),
    };
    let mtl_path = resolve_asset_from(obj_dir, obj_path, &field, &name)?;
    let text = read_text(&mtl_path)?;
    let map_kd_lines = scan_mtl(&mtl_path, &text)?;
    let (materials, names) = tobj::load_mtl_buf(&mut text.as_bytes())
        .map_err(|e| Error::invalid(&mtl_path, "MTL data", format!("cannot parse MTL: {e}")))?;
    let library = MtlLibrary {
        path: mtl_path,
        count: materials.len(),
        map_kd_lines,
    };
    Ok((library, Ok((materials, names))))
}

/// Checks the MTL lines tobj interprets (see `parse_mtl_line` in tobj 4.0; its colour parser
/// panics on fewer than three numbers) and returns the line of each material's `map_Kd`.
fn scan_mtl(path: &Path, text: &str) -> Result<HashMap<String, usize>> {
    let mut map_kd_lines = HashMap::new();
    let mut current = String::new();
    for (index, raw_line) in text.lines().enumerate() {
        let line_no = index + 1;
        let err = |message: String| Error::invalid(path, format!("line {line_no}"), message);
        let line = raw_line.trim();
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        let args: Vec<&str> = words.collect();
        let rest = line[keyword.len()..].trim();
        match keyword {
            "newmtl" => {
                if rest.is_empty() {
                    return Err(err("'newmtl' without a name".to_string()));
                }
                current = rest.to_string();
            }
            "Ka" | "Kd" | "Ks" | "Ke" => {
                let rgb = parse_floats::<3>(&args).ok_or_else(|| {
                    err(format!(
                        "expected 3 numbers after '{keyword}' (r g b), got '{rest}'"
                    ))
                })?;
                let rgb = Vec3::from_array(rgb);
                if !rgb.is_finite() {
                    return Err(err(format!("'{keyword}' is not finite: '{rest}'")));
                }
                if keyword == "Ke" && rgb.min_element() < 0.0 {
                    return Err(err(format!("'Ke' (emission) is negative: '{rest}'")));
                }
                if keyword == "Ke" {
                    super::animation::check_light_value(rgb)
                        .map_err(|m| err(format!("'Ke' (emission): {m}")))?;
                }
            }
            "Ns" | "Ni" | "d" if parse_floats::<1>(&args).is_none() => {
                return Err(err(format!("expected a number after '{keyword}'")));
            }
            "Ns" | "Ni" | "d" => {
                let value = parse_floats::<1>(&args).map_or(f32::NAN, |[v]| v);
                if !value.is_finite() {
                    return Err(err(format!("'{keyword}' is not finite: '{rest}'")));
                }
                let max = super::limits::MAX_PHONG_EXPONENT;
                if keyword == "Ns" && value > max {
                    return Err(err(format!(
                        "'Ns' (the Phong exponent) {value} is above {max:e}, a mirror in \
                         effect; radsplat's glossy lobes stay exact below it"
                    )));
                }
            }
            "illum" if args.first().and_then(|w| w.parse::<u8>().ok()).is_none() => {
                return Err(err(
                    "expected an illumination model number (0..255) after 'illum'".to_string(),
                ));
            }
            "map_Ka" | "map_Kd" | "map_Ks" | "map_Bump" | "map_bump" | "map_Ns" | "map_ns"
            | "map_NS" | "bump" | "map_d" => {
                if rest.is_empty() {
                    return Err(err(format!("'{keyword}' without a file name")));
                }
                if keyword == "map_Kd" {
                    map_kd_lines.insert(current.clone(), line_no);
                }
            }
            _ => {}
        }
    }
    Ok(map_kd_lines)
}

/// The file name of an MTL map statement's argument. Options such as `-s 1 1 1` or `-bm 0.5`
/// may precede the name; then the name is the last word. Backslashes (Windows exporters) are
/// turned into slashes.
fn texture_file_name(argument: &str) -> String {
    let name = if argument.starts_with('-') {
        argument.split_whitespace().last().unwrap_or(argument)
    } else {
        argument
    };
    name.replace('\\', "/")
}

/// Turns tobj's materials into ours, resolving texture paths relative to their MTL file.
fn convert_materials(
    materials: &[tobj::Material],
    libraries: &[MtlLibrary],
) -> Result<Vec<ObjMaterial>> {
    // tobj appends the materials of each library in load order.
    let owners = libraries
        .iter()
        .flat_map(|library| std::iter::repeat_n(library, library.count));
    let mut out = Vec::with_capacity(materials.len());
    for (material, library) in materials.iter().zip(owners) {
        let texture = match &material.diffuse_texture {
            Some(argument) => {
                let field = match library.map_kd_lines.get(&material.name) {
                    Some(line) => format!("line {line}, map_Kd of material '{}'", material.name),
                    None => format!("map_Kd of material '{}'", material.name),
                };
                let name = texture_file_name(argument);
                Some(resolve_asset_from(
                    parent_dir(&library.path),
                    &library.path,
                    &field,
                    &name,
                )?)
            }
            None => None,
        };
        // MTL multiplies map_Kd by Kd; without Kd a texture is shown as it is.
        let default_albedo = if texture.is_some() {
            1.0
        } else {
            DEFAULT_ALBEDO
        };
        let albedo = material
            .diffuse
            .map_or(Vec3::splat(default_albedo), Vec3::from_array)
            .clamp(Vec3::ZERO, Vec3::ONE);
        let emission = material
            .emissive
            .map_or(Vec3::ZERO, Vec3::from_array)
            .max(Vec3::ZERO);
        let glossy = mtl_glossy_lobe(material, albedo, &library.path);
        out.push(ObjMaterial {
            material: Material {
                name: material.name.clone(),
                albedo,
                albedo_texture: None,
                emission,
                sampled_light: false,
                glossy,
            },
            texture,
            library: Some(library.path.clone()),
        });
    }
    Ok(out)
}

/// The glossy lobe of an MTL material: Phong with `Ks` and exponent `Ns` (default 1), on
/// illumination models 2 and up ("highlight on") or when `illum` is absent; none when `Ks`
/// is black. MTL files often have `Kd + Ks > 1`; the lobe is then scaled down to conserve
/// energy (`Kd + Ks <= 1` per channel), with a warning naming the material.
fn mtl_glossy_lobe(
    material: &tobj::Material,
    albedo: Vec3,
    library: &std::path::Path,
) -> Option<GlossyLobe> {
    if material.illumination_model.is_some_and(|m| m < 2) {
        return None;
    }
    let specular = material
        .specular
        .map_or(Vec3::ZERO, Vec3::from_array)
        .clamp(Vec3::ZERO, Vec3::ONE);
    if specular.max_element() <= 0.0 {
        return None;
    }
    let exponent = material.shininess.unwrap_or(1.0).max(0.0);
    let room = (Vec3::ONE - albedo).max(Vec3::ZERO);
    let over = (specular / room.max(Vec3::splat(1e-6))).max_element();
    let specular = if over > 1.0 {
        log::warn!(
            "{}: material '{}': Kd + Ks exceeds 1 ({} + {}); Ks scaled by {:.3} to conserve \
             energy",
            library.display(),
            material.name,
            albedo,
            specular,
            1.0 / over
        );
        specular / over
    } else {
        specular
    };
    Some(GlossyLobe::Phong { specular, exponent })
}

/// The default material for faces without one.
pub fn default_material() -> Material {
    Material {
        name: DEFAULT_MATERIAL_NAME.to_string(),
        albedo: Vec3::splat(DEFAULT_ALBEDO),
        albedo_texture: None,
        emission: Vec3::ZERO,
        sampled_light: false,
        glossy: None,
    }
}

/// Concatenates tobj's models into one mesh, fixing normals and dropping degenerate triangles.
fn assemble_mesh(
    path: &Path,
    models: Vec<tobj::Model>,
    mut materials: Vec<ObjMaterial>,
) -> Result<ObjData> {
    let too_big = || Error::invalid(path, "OBJ data", "more than 2^32 vertices");
    let material_count = materials.len();
    let mut default_id: Option<u32> = None;
    let mut mesh = Mesh {
        name: path
            .file_stem()
            .map_or_else(|| "mesh".to_string(), |s| s.to_string_lossy().into_owned()),
        ..Mesh::default()
    };
    let mut stats = ObjStats::default();
    let mut misaligned_models = 0usize;

    for model in models {
        let m = model.mesh;
        let vertex_count = m.positions.len() / 3;
        let base = u32::try_from(mesh.positions.len()).map_err(|_| too_big())?;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        // tobj pushes a normal/uv only for face vertices that have one, so if some vertices of
        // a model lack them the arrays no longer line up with the positions: drop them.
        if m.normals.len() == vertex_count * 3 {
            for n in m.normals.chunks_exact(3) {
                let normal = sanitize_normal(Vec3::new(n[0], n[1], n[2]));
                stats.unusable_normals += usize::from(normal == Vec3::ZERO);
                mesh.normals.push(normal);
            }
        } else {
            misaligned_models += usize::from(!m.normals.is_empty());
            stats.missing_normals += vertex_count;
            mesh.normals.resize(mesh.positions.len(), Vec3::ZERO);
        }
        if m.texcoords.len() == vertex_count * 2 {
            mesh.uvs
                .extend(m.texcoords.chunks_exact(2).map(|t| Vec2::new(t[0], t[1])));
        } else {
            misaligned_models += usize::from(!m.texcoords.is_empty());
            mesh.uvs.resize(mesh.positions.len(), Vec2::ZERO);
        }
        let material_id = match m.material_id {
            Some(id) if id < material_count => id as u32,
            _ => *default_id.get_or_insert_with(|| {
                materials.push(ObjMaterial {
                    material: default_material(),
                    texture: None,
                    library: None,
                });
                (materials.len() - 1) as u32
            }),
        };
        for tri in m.indices.chunks_exact(3) {
            let offset = |i: u32| base.checked_add(i).ok_or_else(too_big);
            mesh.indices
                .push([offset(tri[0])?, offset(tri[1])?, offset(tri[2])?]);
            mesh.material_ids.push(material_id);
        }
    }
    if misaligned_models > 0 {
        log::warn!(
            "{}: {misaligned_models} objects mix faces with and without normals or texture \
             coordinates; those normals/coordinates were dropped",
            path.display()
        );
    }
    stats.triangles_read = mesh.indices.len();
    stats.degenerate_dropped = drop_degenerate_triangles(&mut mesh);
    if stats.degenerate_dropped > 0 {
        log::warn!(
            "{}: dropped {} degenerate triangles (of {})",
            path.display(),
            stats.degenerate_dropped,
            stats.triangles_read
        );
    }
    if stats.unusable_normals > 0 {
        log::info!(
            "{}: {} vertex normals unusable (zero or not finite); \
             shading uses the geometric normal there",
            path.display(),
            stats.unusable_normals
        );
    }
    Ok(ObjData {
        mesh,
        materials,
        stats,
    })
}

/// Unit normal, or zero when `n` has no usable direction.
fn sanitize_normal(n: Vec3) -> Vec3 {
    let unit = n.normalize_or_zero();
    if unit.is_finite() { unit } else { Vec3::ZERO }
}

/// Removes triangles with a repeated vertex or an area of at most
/// `DEGENERATE_AREA_FRACTION * bbox_diagonal^2`; returns how many were removed.
fn drop_degenerate_triangles(mesh: &mut Mesh) -> usize {
    let (min, max) = mesh.positions.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p.as_dvec3()), hi.max(p.as_dvec3())),
    );
    let diagonal_sq = if mesh.positions.is_empty() {
        0.0
    } else {
        (max - min).length_squared()
    };
    // area = |cross| / 2, so area <= f * d^2  <=>  |cross|^2 <= (2 f d^2)^2.
    let limit = 2.0 * DEGENERATE_AREA_FRACTION * diagonal_sq;
    let limit_sq = limit * limit;
    let positions = &mesh.positions;
    let keep: Vec<bool> = mesh
        .indices
        .iter()
        .map(|&[a, b, c]| {
            if a == b || b == c || a == c {
                return false;
            }
            let p = |i: u32| positions[i as usize].as_dvec3();
            let cross = (p(b) - p(a)).cross(p(c) - p(a));
            cross.length_squared() > limit_sq
        })
        .collect();
    let before = mesh.indices.len();
    let mut flags = keep.iter();
    mesh.indices.retain(|_| *flags.next().unwrap_or(&true));
    let mut flags = keep.iter();
    mesh.material_ids.retain(|_| *flags.next().unwrap_or(&true));
    before - mesh.indices.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_are_normalised_or_zero() {
        assert_eq!(sanitize_normal(Vec3::new(0.0, 2.0, 0.0)), Vec3::Y);
        assert_eq!(sanitize_normal(Vec3::ZERO), Vec3::ZERO);
        assert_eq!(sanitize_normal(Vec3::new(f32::NAN, 0.0, 1.0)), Vec3::ZERO);
        assert_eq!(sanitize_normal(Vec3::splat(f32::MAX)), Vec3::ZERO);
    }

    #[test]
    fn texture_options_are_skipped() {
        assert_eq!(texture_file_name("-s 1 1 1 -bm 0.5 a.png"), "a.png");
        assert_eq!(texture_file_name("my texture.png"), "my texture.png");
        assert_eq!(texture_file_name("tex\\a.jpg"), "tex/a.jpg");
    }

    /// A large OBJ (many pieces): `n` quads of fresh vertices, with `usemtl` lines at
    /// the start, the middle and the end, and `extra` inserted after line `at` (1-based).
    fn big_obj(n: usize, at: usize, extra: &str) -> String {
        let mut lines = vec!["mtllib a.mtl".to_string(), "usemtl first".to_string()];
        for i in 0..n {
            let x = i as f32;
            for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
                lines.push(format!("v {} {} 0.5", x + dx, dy));
            }
            if i == n / 2 {
                lines.push("usemtl middle".to_string());
                lines.push("usemtl first".to_string());
            }
            lines.push("f -4 -3 -2 -1".to_string());
        }
        lines.push("usemtl last".to_string());
        lines.insert(at, extra.to_string());
        lines.join("\n") + "\n"
    }

    #[test]
    fn pieces_cover_the_text_at_line_ends() {
        let text = big_obj(20_000, 1, "# comment");
        let pieces = line_pieces(&text);
        assert!(pieces.len() > 1, "one piece for {} bytes", text.len());
        let mut joined = String::new();
        for p in &pieces {
            assert_eq!(p.first_line, joined.matches('\n').count());
            joined.push_str(p.text);
            assert!(p.text.ends_with('\n'));
        }
        assert_eq!(joined, text);
    }

    /// The checks run on every core over pieces of lines, and say what one pass over the
    /// whole file would: the first error's line, forward face references resolved against
    /// the whole file, each material name at its first line.
    #[test]
    fn checks_over_pieces_report_the_lines_of_one_pass() {
        let path = Path::new("big.obj");
        let n = 20_000;
        let ok = big_obj(n, 1, "# comment");
        let scan = scan_obj(path, &ok).expect("valid OBJ");
        let names =
            |l: &[(usize, String)]| -> Vec<String> { l.iter().map(|(_, n)| n.clone()).collect() };
        assert_eq!(names(&scan.usemtls), ["first", "middle", "last"]);
        let middle_line = ok
            .lines()
            .position(|l| l == "usemtl middle")
            .expect("middle")
            + 1;
        assert_eq!(scan.usemtls[1].0, middle_line);
        assert_eq!(scan.usemtls[0].0, 3);
        // A face near the end refers forward to a vertex defined later: allowed.
        let late = 5 * n - 10;
        assert!(scan_obj(path, &big_obj(n, late, "f 1 2 80000")).is_ok());
        // ...but not beyond the file's last vertex: the error names that line.
        let err = scan_obj(path, &big_obj(n, late, "f 1 2 80001"))
            .expect_err("out of range")
            .to_string();
        assert!(err.contains(&format!("line {}", late + 1)), "{err}");
        // Of two bad lines, the earlier one is reported, far apart in the file.
        let mut two = big_obj(n, late, "v 1 nan 2");
        two = two.replacen("f -4 -3 -2 -1\n", "v 1 2\nf -4 -3 -2 -1\n", 1);
        let err = scan_obj(path, &two).expect_err("bad vertices").to_string();
        assert!(err.contains("line 7:"), "{err}");
        // A control character deep in the file, caught by the text check with its line.
        let bad = big_obj(n, late, "v 1 2 \u{1} 3");
        let err = check_text(path, &bad).expect_err("control").to_string();
        assert!(err.contains(&format!("line {}", late + 1)), "{err}");
    }

    #[test]
    fn face_indices_are_range_checked() {
        let seen = ElementCounts {
            positions: 3,
            texcoords: 0,
            normals: 3,
        };
        let totals = ElementCounts {
            positions: 4,
            texcoords: 0,
            normals: 3,
        };
        assert!(check_face_vertex("4//-3", &seen, &totals).is_ok());
        assert!(check_face_vertex("-3", &seen, &totals).is_ok());
        assert!(check_face_vertex("-4", &seen, &totals).is_err());
        assert!(check_face_vertex("5", &seen, &totals).is_err());
        assert!(check_face_vertex("0", &seen, &totals).is_err());
        assert!(check_face_vertex("1/1", &seen, &totals).is_err());
        assert!(check_face_vertex("/1/1", &seen, &totals).is_err());
        assert!(check_face_vertex("1/2/3/4", &seen, &totals).is_err());
    }

    #[test]
    fn positions_must_be_finite() {
        assert!(check_position(&["1", "2", "3"]).is_ok());
        assert!(check_position(&["1", "2", "3", "0.5"]).is_ok());
        assert!(check_position(&["1", "2", "3", "0"]).is_err());
        assert!(check_position(&["nan", "2", "3"]).is_err());
        assert!(check_position(&["1", "inf", "3"]).is_err());
        assert!(check_position(&["1e38", "0", "0", "1e-38"]).is_err());
        assert!(check_position(&["1", "2"]).is_err());
        assert!(check_position(&["1", "2", "3", "4", "5"]).is_err());
    }

    #[test]
    fn degenerate_triangles_are_dropped() {
        let mut mesh = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X * 2.0],
            indices: vec![[0, 1, 2], [0, 1, 3], [0, 0, 2]],
            material_ids: vec![0, 1, 2],
            ..Mesh::default()
        };
        assert_eq!(drop_degenerate_triangles(&mut mesh), 2);
        assert_eq!(mesh.indices, vec![[0, 1, 2]]);
        assert_eq!(mesh.material_ids, vec![0]);
    }
}
