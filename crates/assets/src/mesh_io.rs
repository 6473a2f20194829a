//! Mesh loaders: OBJ, PLY and glTF/GLB into a [`relight_geom::Mesh`].
//!
//! Every loader merges all objects/primitives of the file into one mesh in
//! the file's (world) frame, then runs [`Mesh::validate_and_repair`] and
//! returns its [`RepairReport`](relight_geom::RepairReport) inside the [`LoadReport`] (with one warning
//! line per repair). A file with no valid triangle left is an
//! [`AssetError::EmptyMesh`].
//!
//! * **OBJ** (`tobj`): polygons triangulated, one index per vertex (a vertex
//!   is split where its normal/uv differ), materials ignored.
//! * **PLY** (own reader): `ascii 1.0`, `binary_little_endian 1.0` and
//!   `binary_big_endian 1.0`; vertex properties `x y z`, optional `nx ny nz`
//!   and `u v` / `s t` / `texture_u texture_v`; faces as a list property
//!   `vertex_indices` (or `vertex_index`), polygons fan-triangulated; any
//!   other element or property is skipped.
//! * **glTF 2.0 / GLB** (`gltf` JSON model, buffers read here): `.glb` with
//!   its BIN chunk, `.gltf` with base64 `data:` URIs or external `.bin`
//!   files next to it. The default scene (else the first, else every mesh)
//!   is walked with node transforms applied (normals by the inverse
//!   transpose). Primitive modes TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN;
//!   points and lines are skipped with a warning. Files that *require* an
//!   extension relight cannot decode — notably `KHR_draco_mesh_compression`
//!   and `EXT_meshopt_compression` — fail with [`AssetError::Unsupported`]
//!   naming the extension. Every accessor is bounds-checked against its
//!   buffer view and buffer before it is read.
//!
//! uv convention: glTF's (origin top-left, v down). OBJ and PLY store v up,
//! so their v is flipped (`v ← 1 − v`).

use crate::error::{AssetError, LoadReport, guard};
use glam::{Mat4, Vec2, Vec3};
use relight_geom::Mesh;
use std::path::Path;

/// Mesh file formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    Obj,
    Ply,
    Gltf,
}

const MESH_EXTS: &str = ".obj, .ply, .gltf or .glb";

impl MeshFormat {
    /// The format named by the file extension.
    pub fn from_path(path: &Path) -> Result<Self, AssetError> {
        crate::error::format_by_extension(path, |ext| match ext {
            "obj" => Some(Self::Obj),
            "ply" => Some(Self::Ply),
            "gltf" | "glb" => Some(Self::Gltf),
            _ => None,
        })?
        .ok_or_else(|| AssetError::UnknownFormat {
            path: path.to_path_buf(),
            ext: crate::error::lowercase_extension(path),
            expected: MESH_EXTS,
        })
    }
}

/// Loads a mesh by extension, validated and repaired.
pub fn load_mesh(path: &Path) -> Result<(Mesh, LoadReport), AssetError> {
    let format = MeshFormat::from_path(path)?;
    let bytes = crate::read_bytes(path)?;
    decode_mesh(&bytes, format, path)
}

/// Decodes an in-memory mesh; `path` names it in messages and locates
/// external glTF buffers.
pub fn decode_mesh(
    bytes: &[u8],
    format: MeshFormat,
    path: &Path,
) -> Result<(Mesh, LoadReport), AssetError> {
    let mut report = LoadReport::default();
    let mut mesh = match format {
        MeshFormat::Obj => guard(path, "OBJ", || decode_obj(bytes, path))?,
        MeshFormat::Ply => decode_ply(bytes, path)?,
        MeshFormat::Gltf => guard(path, "glTF", || {
            decode_gltf(bytes, path, &mut report.warnings)
        })?,
    };
    let before = mesh.triangle_count();
    let repair = mesh.validate_and_repair();
    for w in repair.warnings() {
        report.warnings.push(format!("{}: {w}", path.display()));
    }
    if mesh.triangle_count() == 0 {
        return Err(AssetError::EmptyMesh {
            path: path.to_path_buf(),
            detail: format!(
                "{before} triangle(s) read, {} vertices; {repair}",
                mesh.vertex_count()
            ),
        });
    }
    report.repair = Some(repair);
    Ok((mesh, report))
}

fn flip_v(uv: Vec2) -> Vec2 {
    Vec2::new(uv.x, 1.0 - uv.y)
}

// ---------------------------------------------------------------- OBJ

fn decode_obj(bytes: &[u8], path: &Path) -> Result<Mesh, AssetError> {
    let mut reader = std::io::BufReader::new(bytes);
    let (models, _materials) = tobj::load_obj_buf(&mut reader, &tobj::GPU_LOAD_OPTIONS, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| AssetError::corrupt(path, format!("OBJ: {e}")))?;
    let mut mesh = Mesh::default();
    for m in &models {
        let tm = &m.mesh;
        let n = tm.positions.len() / 3;
        let mut part = Mesh {
            positions: tm
                .positions
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]))
                .collect(),
            normals: tm
                .normals
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]))
                .collect(),
            uvs: tm
                .texcoords
                .chunks_exact(2)
                .map(|c| flip_v(Vec2::new(c[0], c[1])))
                .collect(),
            tangents: Vec::new(),
            indices: tm
                .indices
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect(),
        };
        if part.normals.len() != n {
            part.normals.clear();
        }
        if part.uvs.len() != n {
            part.uvs.clear();
        }
        if mesh.positions.is_empty() {
            mesh = part;
        } else {
            mesh.merge(&part);
        }
    }
    Ok(mesh)
}

// ---------------------------------------------------------------- PLY

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PlyType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl PlyType {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }
}

#[derive(Debug)]
struct PlyProperty {
    name: String,
    /// `Some(count type)` for a list property.
    list: Option<PlyType>,
    ty: PlyType,
}

#[derive(Debug)]
struct PlyElement {
    name: String,
    count: usize,
    props: Vec<PlyProperty>,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum PlyEncoding {
    Ascii,
    Le,
    Be,
}

/// Sequential reader of PLY values in one of the three encodings.
struct PlyBody<'a> {
    bytes: &'a [u8],
    pos: usize,
    enc: PlyEncoding,
    path: &'a Path,
}

impl PlyBody<'_> {
    fn read(&mut self, ty: PlyType) -> Result<f64, AssetError> {
        if self.enc == PlyEncoding::Ascii {
            while self.pos < self.bytes.len() && self.bytes[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            let start = self.pos;
            while self.pos < self.bytes.len() && !self.bytes[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            if start == self.pos {
                return Err(AssetError::truncated(
                    self.path,
                    "PLY body ends before all elements were read",
                ));
            }
            let tok = std::str::from_utf8(&self.bytes[start..self.pos]).unwrap_or("?");
            return tok.parse::<f64>().map_err(|_| {
                AssetError::corrupt(self.path, format!("PLY: `{tok}` is not a number"))
            });
        }
        let n = ty.size();
        let Some(b) = self.bytes.get(self.pos..self.pos + n) else {
            return Err(AssetError::truncated(
                self.path,
                "PLY body ends before all elements were read",
            ));
        };
        self.pos += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.enc == PlyEncoding::Be {
            a[..n].reverse();
        }
        Ok(match ty {
            PlyType::I8 => f64::from(a[0] as i8),
            PlyType::U8 => f64::from(a[0]),
            PlyType::I16 => f64::from(i16::from_le_bytes([a[0], a[1]])),
            PlyType::U16 => f64::from(u16::from_le_bytes([a[0], a[1]])),
            PlyType::I32 => f64::from(i32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            PlyType::U32 => f64::from(u32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            PlyType::F32 => f64::from(f32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            PlyType::F64 => f64::from_le_bytes(a),
        })
    }
}

fn decode_ply(bytes: &[u8], path: &Path) -> Result<Mesh, AssetError> {
    let corrupt = |m: String| AssetError::corrupt(path, format!("PLY: {m}"));
    if !bytes.starts_with(b"ply") {
        return Err(if bytes.len() < 3 {
            AssetError::truncated(path, "too short for a PLY header")
        } else {
            corrupt("missing `ply` magic".into())
        });
    }
    let marker = b"end_header";
    let hend = bytes
        .windows(marker.len())
        .position(|w| w == marker)
        .ok_or_else(|| AssetError::truncated(path, "PLY header has no `end_header`"))?;
    let mut body_start = hend + marker.len();
    if bytes.get(body_start) == Some(&b'\r') {
        body_start += 1;
    }
    if bytes.get(body_start) == Some(&b'\n') {
        body_start += 1;
    }
    let header = String::from_utf8_lossy(&bytes[..hend]);
    let mut enc = None;
    let mut elements: Vec<PlyElement> = Vec::new();
    for line in header.lines().skip(1) {
        let t: Vec<&str> = line.split_whitespace().collect();
        match t.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _ver] => {
                enc = Some(match *f {
                    "ascii" => PlyEncoding::Ascii,
                    "binary_little_endian" => PlyEncoding::Le,
                    "binary_big_endian" => PlyEncoding::Be,
                    other => {
                        return Err(AssetError::unsupported(
                            path,
                            format!("PLY format `{other}`"),
                        ));
                    }
                });
            }
            ["element", name, count] => elements.push(PlyElement {
                name: (*name).to_string(),
                count: count
                    .parse()
                    .map_err(|_| corrupt(format!("bad element count `{count}`")))?,
                props: Vec::new(),
            }),
            ["property", "list", ct, it, name] => {
                let el = elements
                    .last_mut()
                    .ok_or_else(|| corrupt("property before any element".into()))?;
                let (Some(ct), Some(it)) = (PlyType::parse(ct), PlyType::parse(it)) else {
                    return Err(corrupt(format!("unknown list types in `{line}`")));
                };
                el.props.push(PlyProperty {
                    name: (*name).to_string(),
                    list: Some(ct),
                    ty: it,
                });
            }
            ["property", ty, name] => {
                let el = elements
                    .last_mut()
                    .ok_or_else(|| corrupt("property before any element".into()))?;
                let ty = PlyType::parse(ty)
                    .ok_or_else(|| corrupt(format!("unknown type in `{line}`")))?;
                el.props.push(PlyProperty {
                    name: (*name).to_string(),
                    list: None,
                    ty,
                });
            }
            _ => return Err(corrupt(format!("unexpected header line `{line}`"))),
        }
    }
    let enc = enc.ok_or_else(|| corrupt("no `format` line".into()))?;
    let remaining = bytes.len() - body_start;
    let mut body = PlyBody {
        bytes,
        pos: body_start,
        enc,
        path,
    };
    let mut mesh = Mesh::default();
    for el in &elements {
        // Each element needs at least one byte per value (binary) or two
        // (ASCII value + separator): reject counts the file cannot hold
        // before allocating for them.
        let min_bytes = el
            .props
            .iter()
            .map(|p| p.list.unwrap_or(p.ty).size())
            .sum::<usize>()
            .max(1);
        let min_bytes = if enc == PlyEncoding::Ascii {
            2 * el.props.len().max(1)
        } else {
            min_bytes
        };
        if el.count.saturating_mul(min_bytes) > remaining {
            return Err(AssetError::truncated(
                path,
                format!(
                    "PLY element `{}` claims {} items, more than the file holds",
                    el.name, el.count
                ),
            ));
        }
        let find = |names: &[&str]| {
            el.props
                .iter()
                .position(|p| p.list.is_none() && names.contains(&p.name.as_str()))
        };
        match el.name.as_str() {
            "vertex" => {
                let xyz = [find(&["x"]), find(&["y"]), find(&["z"])];
                let nrm = [find(&["nx"]), find(&["ny"]), find(&["nz"])];
                let uv = [
                    find(&["u", "s", "texture_u", "texture_s"]),
                    find(&["v", "t", "texture_v", "texture_t"]),
                ];
                if xyz.iter().any(Option::is_none) {
                    return Err(corrupt("vertex element lacks x, y or z".into()));
                }
                let has_n = nrm.iter().all(Option::is_some);
                let has_uv = uv.iter().all(Option::is_some);
                let mut vals = vec![0.0f64; el.props.len()];
                for _ in 0..el.count {
                    for (k, p) in el.props.iter().enumerate() {
                        vals[k] = read_prop(&mut body, p)?;
                    }
                    let g = |i: Option<usize>| vals[i.unwrap_or(0)] as f32;
                    mesh.positions
                        .push(Vec3::new(g(xyz[0]), g(xyz[1]), g(xyz[2])));
                    if has_n {
                        mesh.normals
                            .push(Vec3::new(g(nrm[0]), g(nrm[1]), g(nrm[2])));
                    }
                    if has_uv {
                        mesh.uvs.push(flip_v(Vec2::new(g(uv[0]), g(uv[1]))));
                    }
                }
            }
            "face" => {
                let li = el
                    .props
                    .iter()
                    .position(|p| {
                        p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index")
                    })
                    .ok_or_else(|| corrupt("face element has no `vertex_indices` list".into()))?;
                let mut poly = Vec::new();
                for _ in 0..el.count {
                    for (k, p) in el.props.iter().enumerate() {
                        if k == li {
                            poly.clear();
                            let n = body.read(p.list.unwrap_or(PlyType::U8))?;
                            if !(0.0..=1024.0).contains(&n) {
                                return Err(corrupt(format!("face with {n} vertices")));
                            }
                            for _ in 0..n as usize {
                                let i = body.read(p.ty)?;
                                // Negative or huge indices become u32::MAX: dropped by repair.
                                poly.push(if (0.0..4e9).contains(&i) {
                                    i as u32
                                } else {
                                    u32::MAX
                                });
                            }
                            for j in 1..poly.len().saturating_sub(1) {
                                mesh.indices.push([poly[0], poly[j], poly[j + 1]]);
                            }
                        } else {
                            read_prop(&mut body, p)?;
                        }
                    }
                }
            }
            _ => {
                for _ in 0..el.count {
                    for p in &el.props {
                        read_prop(&mut body, p)?;
                    }
                }
            }
        }
    }
    Ok(mesh)
}

/// Reads one property value (a list is read and discarded; returns 0).
fn read_prop(body: &mut PlyBody<'_>, p: &PlyProperty) -> Result<f64, AssetError> {
    match p.list {
        None => body.read(p.ty),
        Some(ct) => {
            let n = body.read(ct)?;
            if !(0.0..=1e6).contains(&n) {
                return Err(AssetError::corrupt(
                    body.path,
                    format!("PLY list of length {n}"),
                ));
            }
            for _ in 0..n as usize {
                body.read(p.ty)?;
            }
            Ok(0.0)
        }
    }
}

// ---------------------------------------------------------------- glTF

/// Required extensions relight cannot decode, named in the error.
const UNDECODABLE_EXTENSIONS: [&str; 3] = [
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_mesh_quantization",
];

/// A GLB container error in words (the gltf crate's `Display` names no
/// numbers, its `Debug` is Rust syntax).
fn glb_error(path: &Path, b: &gltf::binary::Error) -> AssetError {
    use gltf::binary::{ChunkType, Error as E};
    let chunk = |ty: &ChunkType| match ty {
        ChunkType::Json => "JSON",
        ChunkType::Bin => "BIN",
    };
    match b {
        E::Length {
            length,
            length_read,
        } => AssetError::truncated(
            path,
            format!("GLB header says {length} bytes, the file has {length_read}"),
        ),
        E::ChunkLength {
            ty,
            length,
            length_read,
        } => AssetError::truncated(
            path,
            format!(
                "GLB {} chunk says {length} bytes, {length_read} are left",
                chunk(ty)
            ),
        ),
        E::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            AssetError::truncated(path, "GLB ends inside its 12-byte header")
        }
        E::Io(io) => AssetError::corrupt(path, format!("GLB: {io}")),
        E::Version(v) => {
            AssetError::unsupported(path, format!("GLB version {v} (relight reads version 2)"))
        }
        E::Magic(m) => AssetError::corrupt(
            path,
            format!(
                "not a GLB file (starts with {:?}, not \"glTF\")",
                String::from_utf8_lossy(m)
            ),
        ),
        E::ChunkType(ty) => {
            AssetError::corrupt(path, format!("GLB: unexpected {} chunk", chunk(ty)))
        }
        E::UnknownChunkType(t) => AssetError::corrupt(
            path,
            format!("GLB: unknown chunk type {:?}", String::from_utf8_lossy(t)),
        ),
    }
}

fn decode_gltf(bytes: &[u8], path: &Path, warnings: &mut Vec<String>) -> Result<Mesh, AssetError> {
    let gerr = |e: gltf::Error| match e {
        gltf::Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            AssetError::truncated(path, format!("glTF: {io}"))
        }
        gltf::Error::Binary(b) => glb_error(path, &b),
        other => AssetError::corrupt(path, format!("glTF: {other}")),
    };
    let g = gltf::Gltf::from_slice_without_validation(bytes).map_err(gerr)?;
    let required: Vec<String> = g
        .document
        .extensions_required()
        .map(str::to_string)
        .collect();
    if let Some(ext) = required
        .iter()
        .find(|e| UNDECODABLE_EXTENSIONS.contains(&e.as_str()))
    {
        return Err(AssetError::unsupported(
            path,
            format!(
                "glTF required extension `{ext}` (relight reads plain glTF buffers; re-export without {ext})"
            ),
        ));
    }
    // Parse again with validation (gltf exposes validation only this way).
    let g = gltf::Gltf::from_slice(bytes).map_err(gerr)?;
    for ext in &required {
        warnings.push(format!(
            "{}: ignoring required glTF extension `{ext}`",
            path.display()
        ));
    }

    // Buffers.
    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for b in g.document.buffers() {
        let data = match b.source() {
            gltf::buffer::Source::Bin => g.blob.clone().ok_or_else(|| {
                AssetError::corrupt(path, "glTF buffer refers to a missing GLB BIN chunk")
            })?,
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let b64 = rest.split_once(";base64,").map(|(_, d)| d).ok_or_else(|| {
                        AssetError::unsupported(path, "glTF data URI that is not base64")
                    })?;
                    base64_decode(b64)
                        .ok_or_else(|| AssetError::corrupt(path, "glTF data URI: invalid base64"))?
                } else {
                    let dir = path.parent().unwrap_or(Path::new("."));
                    let ext_path = dir.join(uri.replace("%20", " "));
                    // The glTF is the file named: the buffer is its part.
                    crate::read_bytes(&ext_path).map_err(|e| {
                        AssetError::corrupt(path, format!("glTF buffer {}: {e}", b.index()))
                    })?
                }
            }
        };
        if data.len() < b.length() {
            return Err(AssetError::truncated(
                path,
                format!(
                    "glTF buffer {} has {} bytes, declares {}",
                    b.index(),
                    data.len(),
                    b.length()
                ),
            ));
        }
        buffers.push(data);
    }

    let mut out = Mesh::default();
    let mut first = true;
    let mut add =
        |m: &gltf::Mesh<'_>, world: Mat4, warnings: &mut Vec<String>| -> Result<(), AssetError> {
            for prim in m.primitives() {
                let Some(mut part) = read_primitive(&prim, &buffers, path, warnings)? else {
                    continue;
                };
                part.transform_mat4(world);
                if first {
                    out = part;
                    first = false;
                } else {
                    out.merge(&part);
                }
            }
            Ok(())
        };
    let scene = g
        .document
        .default_scene()
        .or_else(|| g.document.scenes().next());
    match scene {
        Some(s) => {
            let mut stack: Vec<(gltf::Node<'_>, Mat4, usize)> =
                s.nodes().map(|n| (n, Mat4::IDENTITY, 0)).collect();
            while let Some((node, parent, depth)) = stack.pop() {
                if depth > 256 {
                    return Err(AssetError::corrupt(
                        path,
                        "glTF node hierarchy deeper than 256 (a cycle?)",
                    ));
                }
                let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
                if let Some(m) = node.mesh() {
                    add(&m, world, warnings)?;
                }
                stack.extend(node.children().map(|c| (c, world, depth + 1)));
            }
        }
        None => {
            for m in g.document.meshes() {
                add(&m, Mat4::IDENTITY, warnings)?;
            }
        }
    }
    Ok(out)
}

/// Bounds-checks an accessor against its view and buffer.
fn check_accessor(
    a: &gltf::Accessor<'_>,
    buffers: &[Vec<u8>],
    path: &Path,
) -> Result<(), AssetError> {
    let name = || format!("glTF accessor {}", a.index());
    if a.sparse().is_some() {
        return Err(AssetError::unsupported(
            path,
            format!("{}: sparse accessors", name()),
        ));
    }
    let view = a.view().ok_or_else(|| {
        AssetError::unsupported(
            path,
            format!(
                "{} has no buffer view (compressed data, e.g. KHR_draco_mesh_compression?)",
                name()
            ),
        )
    })?;
    let buf = buffers
        .get(view.buffer().index())
        .ok_or_else(|| AssetError::corrupt(path, format!("{}: missing buffer", name())))?;
    let view_end = view.offset().checked_add(view.length());
    if view_end.is_none_or(|e| e > buf.len()) {
        return Err(AssetError::truncated(
            path,
            format!("glTF buffer view {} runs past its buffer", view.index()),
        ));
    }
    let stride = view.stride().unwrap_or(a.size());
    if a.count() > 0 {
        let need = (a.count() - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(a.size()))
            .and_then(|x| x.checked_add(a.offset()));
        if need.is_none_or(|n| n > view.length()) {
            return Err(AssetError::truncated(
                path,
                format!("{} runs past its buffer view", name()),
            ));
        }
    }
    Ok(())
}

fn read_primitive(
    prim: &gltf::Primitive<'_>,
    buffers: &[Vec<u8>],
    path: &Path,
    warnings: &mut Vec<String>,
) -> Result<Option<Mesh>, AssetError> {
    use gltf::mesh::Mode;
    let mode = prim.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        warnings.push(format!(
            "{}: skipped a glTF primitive of mode {mode:?}",
            path.display()
        ));
        return Ok(None);
    }
    for (_, a) in prim.attributes() {
        check_accessor(&a, buffers, path)?;
    }
    if let Some(a) = prim.indices() {
        check_accessor(&a, buffers, path)?;
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
    let positions: Vec<Vec3> = reader
        .read_positions()
        .ok_or_else(|| AssetError::corrupt(path, "glTF primitive without POSITION"))?
        .map(Vec3::from)
        .collect();
    let normals: Vec<Vec3> = reader
        .read_normals()
        .map(|it| it.map(Vec3::from).collect())
        .unwrap_or_default();
    let uvs: Vec<Vec2> = reader
        .read_tex_coords(0)
        .map(|it| it.into_f32().map(Vec2::from).collect())
        .unwrap_or_default();
    let idx: Vec<u32> = match reader.read_indices() {
        Some(it) => it.into_u32().collect(),
        None => (0..positions.len() as u32).collect(),
    };
    let indices = match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        Mode::TriangleStrip => (2..idx.len())
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i - 2], idx[i - 1], idx[i]]
                } else {
                    [idx[i - 1], idx[i - 2], idx[i]]
                }
            })
            .collect(),
        _ => (2..idx.len())
            .map(|i| [idx[0], idx[i - 1], idx[i]])
            .collect(),
    };
    let mut m = Mesh {
        positions,
        normals,
        uvs,
        tangents: Vec::new(),
        indices,
    };
    // Drop attributes of the wrong length now, so transform/merge see a
    // consistent mesh; validate_and_repair runs on the merged result.
    let n = m.positions.len();
    if m.normals.len() != n {
        m.normals.clear();
    }
    if m.uvs.len() != n {
        m.uvs.clear();
    }
    Ok(Some(m))
}

/// Standard base64 (RFC 4648, with or without padding).
fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let val = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return None,
        } as u32)
    };
    let clean: Vec<u8> = s
        .bytes()
        .filter(|c| !c.is_ascii_whitespace() && *c != b'=')
        .collect();
    let mut out = Vec::with_capacity(clean.len() * 3 / 4);
    for chunk in clean.chunks(4) {
        let mut acc = 0u32;
        for (i, &c) in chunk.iter().enumerate() {
            acc |= val(c)? << (18 - 6 * i);
        }
        let bytes = acc.to_be_bytes();
        match chunk.len() {
            4 => out.extend_from_slice(&bytes[1..4]),
            3 => out.extend_from_slice(&bytes[1..3]),
            2 => out.push(bytes[1]),
            _ => return None,
        }
    }
    Some(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Writes a PLY file of `m` in the given encoding (test helper).
    pub(crate) fn encode_ply(m: &Mesh, enc: &str) -> Vec<u8> {
        let mut out = format!(
            "ply\nformat {enc} 1.0\ncomment test\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\nelement edge 1\nproperty int a\nproperty int b\nelement face {}\nproperty list uchar int vertex_indices\nproperty uchar flags\nend_header\n",
            m.positions.len(),
            m.indices.len()
        )
        .into_bytes();
        let be = enc == "binary_big_endian";
        let f = |out: &mut Vec<u8>, x: f32| {
            if enc == "ascii" {
                out.extend_from_slice(format!("{x} ").as_bytes());
            } else if be {
                out.extend_from_slice(&x.to_be_bytes());
            } else {
                out.extend_from_slice(&x.to_le_bytes());
            }
        };
        let i = |out: &mut Vec<u8>, x: i32| {
            if enc == "ascii" {
                out.extend_from_slice(format!("{x} ").as_bytes());
            } else if be {
                out.extend_from_slice(&x.to_be_bytes());
            } else {
                out.extend_from_slice(&x.to_le_bytes());
            }
        };
        let b = |out: &mut Vec<u8>, x: u8| {
            if enc == "ascii" {
                out.extend_from_slice(format!("{x} ").as_bytes());
            } else {
                out.push(x);
            }
        };
        for k in 0..m.positions.len() {
            let (p, n, uv) = (m.positions[k], m.normals[k], m.uvs[k]);
            for x in [p.x, p.y, p.z, n.x, n.y, n.z, uv.x, 1.0 - uv.y] {
                f(&mut out, x);
            }
            if enc == "ascii" {
                out.push(b'\n');
            }
        }
        i(&mut out, 0);
        i(&mut out, 1);
        for t in &m.indices {
            b(&mut out, 3);
            for &v in t {
                i(&mut out, v as i32);
            }
            b(&mut out, 7);
            if enc == "ascii" {
                out.push(b'\n');
            }
        }
        out
    }

    fn quad() -> Mesh {
        let mut m = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            ..Default::default()
        };
        m.validate_and_repair();
        m
    }

    #[test]
    fn ply_all_encodings_round_trip() {
        let m = quad();
        for enc in ["ascii", "binary_little_endian", "binary_big_endian"] {
            let bytes = encode_ply(&m, enc);
            let (got, rep) = decode_mesh(&bytes, MeshFormat::Ply, Path::new("q.ply")).unwrap();
            assert_eq!(got.positions, m.positions, "{enc}");
            assert_eq!(got.indices, m.indices, "{enc}");
            assert_eq!(got.normals, m.normals, "{enc}");
            assert_eq!(got.uvs, m.uvs, "{enc}");
            let r = rep.repair.unwrap();
            assert!(
                r.is_clean() && !r.computed_normals && r.computed_tangents,
                "{enc}: {r:?}"
            );
            // Every truncation is an error, never a panic.
            // (An ASCII file cut after its last complete number is still valid.)
            let last = if enc == "ascii" {
                bytes.len() - 3
            } else {
                bytes.len()
            };
            for cut in (0..last).step_by(7) {
                assert!(
                    decode_mesh(&bytes[..cut], MeshFormat::Ply, Path::new("q.ply")).is_err(),
                    "{enc} cut {cut}"
                );
            }
        }
    }

    #[test]
    fn ply_polygons_fan_and_bad_indices_are_dropped() {
        let src = b"ply\nformat ascii 1.0\nelement vertex 5\nproperty double x\nproperty double y\nproperty double z\nelement face 2\nproperty list uchar uint vertex_index\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 2 0\n5 0 1 2 4 3\n3 0 1 77\n";
        let (m, rep) = decode_mesh(src, MeshFormat::Ply, Path::new("p.ply")).unwrap();
        assert_eq!(m.triangle_count(), 3);
        let r = rep.repair.unwrap();
        assert_eq!(r.out_of_range_triangles, 1);
        assert!(
            rep.warnings
                .iter()
                .any(|w| w.contains("p.ply") && w.contains("out-of-range")),
            "{:?}",
            rep.warnings
        );
        // Counts larger than the file are caught before allocating.
        let huge = b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
        assert!(matches!(
            decode_mesh(huge, MeshFormat::Ply, Path::new("h.ply")),
            Err(AssetError::Truncated { .. })
        ));
        let bad = b"ply\nformat xml 1.0\nend_header\n";
        assert!(matches!(
            decode_mesh(bad, MeshFormat::Ply, Path::new("x.ply")),
            Err(AssetError::Unsupported { .. })
        ));
    }

    #[test]
    fn obj_quads_are_triangulated_and_v_flipped() {
        let src = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";
        let (m, rep) = decode_mesh(src, MeshFormat::Obj, Path::new("q.obj")).unwrap();
        assert_eq!(m.triangle_count(), 2);
        assert!(m.uvs.contains(&Vec2::new(0.0, 1.0)) && m.uvs.contains(&Vec2::new(1.0, 0.0)));
        assert!(m.normals.iter().all(|n| n.abs_diff_eq(Vec3::Z, 1e-6)));
        assert!(rep.repair.unwrap().computed_tangents);
        let e = decode_mesh(b"v 0 0 0\n", MeshFormat::Obj, Path::new("e.obj")).unwrap_err();
        assert!(
            matches!(e, AssetError::EmptyMesh { .. }) && e.to_string().contains("e.obj"),
            "{e}"
        );
    }

    /// A minimal glTF with one triangle in a base64 buffer, under a node
    /// that translates by +2 in x and scales y by 3.
    fn tiny_gltf(required: &str) -> String {
        let mut buf = Vec::new();
        for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        for i in [0u16, 1, 2, 0] {
            buf.extend_from_slice(&i.to_le_bytes());
        }
        let b64 = {
            const T: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
            let mut s = String::new();
            for c in buf.chunks(3) {
                let n = (u32::from(c[0]) << 16)
                    | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
                    | u32::from(*c.get(2).unwrap_or(&0));
                for k in 0..=c.len() {
                    s.push(T[(n >> (18 - 6 * k) & 63) as usize] as char);
                }
            }
            s
        };
        format!(
            r#"{{"asset":{{"version":"2.0"}},{required}"scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"mesh":0,"translation":[2,0,0],"scale":[1,3,1]}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
            "buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{b64}"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                         {{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}]}}"#,
            buf.len()
        )
    }

    #[test]
    fn gltf_embedded_buffer_and_node_transform() {
        let src = tiny_gltf("");
        let (m, _) = decode_mesh(src.as_bytes(), MeshFormat::Gltf, Path::new("t.gltf")).unwrap();
        assert_eq!(
            m.positions,
            vec![
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(3.0, 0.0, 0.0),
                Vec3::new(2.0, 3.0, 0.0)
            ]
        );
        assert_eq!(m.indices, vec![[0, 1, 2]]);
        assert!(m.normals.iter().all(|n| n.abs_diff_eq(Vec3::Z, 1e-6)));
        let draco = tiny_gltf(
            r#""extensionsUsed":["KHR_draco_mesh_compression"],"extensionsRequired":["KHR_draco_mesh_compression"],"#,
        );
        let e = decode_mesh(draco.as_bytes(), MeshFormat::Gltf, Path::new("d.gltf")).unwrap_err();
        assert!(matches!(e, AssetError::Unsupported { .. }), "{e}");
        assert!(
            e.to_string().contains("KHR_draco_mesh_compression")
                && e.to_string().contains("d.gltf"),
            "{e}"
        );
        // A missing external buffer names the glTF and the buffer's file.
        let start = src.find("data:application").unwrap();
        let end = start + src[start..].find('"').unwrap();
        let external = format!("{}no-such-buffer.bin{}", &src[..start], &src[end..]);
        let e = decode_mesh(
            external.as_bytes(),
            MeshFormat::Gltf,
            Path::new("/nonexistent/x.gltf"),
        )
        .unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.starts_with("/nonexistent/x.gltf: ")
                && msg.contains("glTF buffer 0: /nonexistent/no-such-buffer.bin: file not found"),
            "{msg}"
        );
        // An accessor running past its view is caught before reading.
        let bad = src.replace(
            r#""byteOffset":36,"byteLength":6"#,
            r#""byteOffset":36,"byteLength":2"#,
        );
        let e = decode_mesh(bad.as_bytes(), MeshFormat::Gltf, Path::new("b.gltf")).unwrap_err();
        assert!(matches!(e, AssetError::Truncated { .. }), "{e}");
    }

    #[test]
    fn base64_matches_known_vectors() {
        assert_eq!(base64_decode("TWFu").unwrap(), b"Man");
        assert_eq!(base64_decode("TWE=").unwrap(), b"Ma");
        assert_eq!(base64_decode("TQ==").unwrap(), b"M");
        assert!(base64_decode("T!==").is_none());
    }
}
