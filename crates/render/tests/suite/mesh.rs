//! Mesh loading: PLY ASCII vs binary (both endiannesses) vs gzip, OBJ groups, bad input.

#[allow(unused_imports)]
use crate::common::*;

use glam::{Mat4, Vec3};
use render::shape::mesh::TriangleMesh;
use std::io::Write;
use std::path::{Path, PathBuf};


fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lucent-mesh-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Test mesh: a unit square as one quad (4 vertices with normals), plus a triangle, with an extra
/// per-vertex property and an extra element that the reader must skip.
fn sample() -> (Vec<[f64; 6]>, Vec<Vec<i32>>) {
    let verts = vec![
        [0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        [1.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        [0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        [0.5, 0.5, 1.25, 0.0, 1.0, 0.0],
    ];
    let faces = vec![vec![0, 1, 2, 3], vec![0, 4, 1]];
    (verts, faces)
}

fn header(format: &str, nv: usize, nf: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\ncomment test\nelement vertex {nv}\nproperty double x\nproperty float y\nproperty float z\n\
         property uchar red\nproperty float nx\nproperty float ny\nproperty float nz\n\
         element face {nf}\nproperty list uchar int vertex_indices\nproperty int flags\n\
         element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n"
    )
}

fn ascii_ply() -> Vec<u8> {
    let (vs, fs) = sample();
    let mut s = header("ascii", vs.len(), fs.len());
    for p in &vs {
        s += &format!("{} {} {} 7 {} {} {}\n", p[0], p[1], p[2], p[3], p[4], p[5]);
    }
    for f in &fs {
        s += &format!("{} {} 3\n", f.len(), f.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(" "));
    }
    s += "0 1\n";
    s.into_bytes()
}

fn binary_ply(big: bool) -> Vec<u8> {
    let (vs, fs) = sample();
    let mut b = header(if big { "binary_big_endian" } else { "binary_little_endian" }, vs.len(), fs.len()).into_bytes();
    macro_rules! put {
        ($x:expr) => {
            if big {
                b.extend_from_slice(&$x.to_be_bytes())
            } else {
                b.extend_from_slice(&$x.to_le_bytes())
            }
        };
    }
    for p in &vs {
        put!(p[0]);
        put!(p[1] as f32);
        put!(p[2] as f32);
        b.push(7u8);
        put!(p[3] as f32);
        put!(p[4] as f32);
        put!(p[5] as f32);
    }
    for f in &fs {
        b.push(f.len() as u8);
        for &i in f {
            put!(i);
        }
        put!(3i32);
    }
    put!(0i32);
    put!(1i32);
    b
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn load_one(p: &Path) -> TriangleMesh {
    let mut v = TriangleMesh::load(p).unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(v.len(), 1);
    v.pop().unwrap().1
}

#[test]
fn ply_ascii_binary_and_gzip_agree() {
    let d = tmp_dir("agree");
    let a = load_one(&write(&d, "a.ply", &ascii_ply()));
    let le = load_one(&write(&d, "le.ply", &binary_ply(false)));
    let be = load_one(&write(&d, "be.ply", &binary_ply(true)));
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(&binary_ply(false)).unwrap();
    let z = load_one(&write(&d, "le.ply.gz", &gz.finish().unwrap()));
    assert_eq!(a, le);
    assert_eq!(a, be);
    assert_eq!(a, z);
    // The quad is fan-triangulated: 2 + 1 triangles; normals were read.
    assert_eq!(a.indices, vec![[0, 1, 2], [0, 2, 3], [0, 4, 1]]);
    assert_eq!(a.positions[4], Vec3::new(0.5, 0.5, 1.25));
    assert_eq!(a.normals.as_ref().unwrap()[4], Vec3::Y);
    // Area: unit square + triangle (0,0,0),(0.5,0.5,1.25),(1,0,0): ½·|(0.5,0.5,1.25)×(1,0,0)|.
    let tri = 0.5 * Vec3::new(0.5, 0.5, 1.25).cross(Vec3::X).length();
    assert!((a.area() - (1.0 + tri)).abs() < 1e-6);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn bundled_meshes_load_with_published_counts() {
    // Counts from data/meshes/README.md.
    for (f, nv, nt) in [("bunny.ply", 1839, 3674), ("teapot.ply", 792, 992), ("dragon-48k.ply", 22998, 47794)] {
        let m = load_one(&repo().join("data/meshes").join(f));
        assert_eq!((m.positions.len(), m.indices.len()), (nv, nt), "{f}");
    }
}

#[test]
fn bunny_is_closed_and_outward() {
    // Signed volume by the divergence theorem is positive for outward winding; a closed mesh
    // has every edge used once in each direction.
    let m = load_one(&repo().join("data/meshes/bunny.ply"));
    let vol: f64 = m
        .indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize].as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    assert!(vol > 0.0);
    let mut edges = std::collections::HashMap::new();
    for t in &m.indices {
        for k in 0..3 {
            *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    for (&(a, b), &n) in &edges {
        assert_eq!(n, 1, "edge {a}->{b} used {n} times");
        assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}->{b} has no twin");
    }
}

#[test]
fn obj_groups_become_named_meshes() {
    let cbox = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/cornell-box/cbox.obj");
    let text = Some(std::fs::read_to_string(&cbox).expect("the repo's copy of the Cornell box OBJ"));
    // A small inline OBJ with two groups, then the repo's Cornell box (gzip-compressed).
    let d = tmp_dir("obj");
    let p = write(
        &d,
        "two.obj",
        b"# two groups\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\ng quad\nf 1 2 3 4\ng tri\nf 1 2 5\n",
    );
    let ms = TriangleMesh::load(&p).unwrap();
    let names: Vec<&str> = ms.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["quad", "tri"]);
    assert_eq!(ms[0].1.indices.len(), 2);
    assert!((ms[0].1.area() - 1.0).abs() < 1e-6);
    assert!((ms[1].1.area() - 0.5).abs() < 1e-6);
    if let Some(t) = text {
        let p = write(&d, "cbox.obj.gz", &{
            let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
            gz.write_all(t.as_bytes()).unwrap();
            gz.finish().unwrap()
        });
        let ms = TriangleMesh::load(&p).unwrap();
        let floor = ms.iter().find(|(n, _)| n == "floor").expect("floor group");
        // Published floor quad (mm): (552.8,0,0) (0,0,0) (0,0,559.2) (549.6,0,559.2).
        let expect = 0.5 * 559.2 * (552.8 + 549.6);
        assert!((floor.1.area() - expect).abs() < 0.5, "floor area {}", floor.1.area());
        assert!(ms.iter().any(|(n, _)| n == "light"));
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn transform_and_quad() {
    let mut q = TriangleMesh::quad([Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]);
    assert!((q.area() - 1.0).abs() < 1e-6);
    q.normals = Some(vec![Vec3::Z; 4]);
    q.transform(&(Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)) * Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0))));
    assert!((q.area() - 6.0).abs() < 1e-5);
    assert_eq!(q.positions[2], Vec3::new(3.0, 5.0, 3.0));
    assert_eq!(q.normals.as_ref().unwrap()[0], Vec3::Z);
    // A mirror keeps the geometric normal (p1−p0)×(p2−p0) on the side of the shading normals.
    q.transform(&Mat4::from_scale(Vec3::new(1.0, 1.0, -1.0)));
    let [a, b, c] = q.triangle(0);
    assert!((b - a).cross(c - a).dot(q.normals.as_ref().unwrap()[0]) > 0.0);
}

fn load_err(name: &str, bytes: &[u8]) -> String {
    let d = tmp_dir("bad");
    let p = write(&d, name, bytes);
    let e = TriangleMesh::load(&p).expect_err("must fail");
    format!("{e:#}")
}

#[test]
fn bad_input_errors_name_file_and_place() {
    let nan = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n";
    let e = load_err("nan.ply", nan.as_bytes());
    assert!(e.contains("nan.ply") && e.contains("vertex 1") && e.contains("line 11"), "{e}");
    let range = nan.replace("1 nan 0", "1 0 0").replace("3 0 1 2", "3 0 1 7");
    let e = load_err("range.ply", range.as_bytes());
    assert!(e.contains("range.ply") && e.contains("face 0") && e.contains("out of range"), "{e}");
    let e = load_err("inf.ply", nan.replace("1 nan 0", "1 inf 0").as_bytes());
    assert!(e.contains("inf.ply") && e.contains("non-finite"), "{e}");
    // Truncated binary body.
    let mut b = binary_ply(false);
    b.truncate(b.len() - 20);
    let e = load_err("trunc.ply", &b);
    assert!(e.contains("trunc.ply") && e.contains("end of file"), "{e}");
    // Not a PLY, unknown type, unknown extension, missing file, bad gzip.
    assert!(load_err("x.ply", b"hello\nend_header\n").contains("not a PLY"));
    let e = load_err("t.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n");
    assert!(e.contains("line 4") && e.contains("quad"), "{e}");
    assert!(load_err("m.stl", b"solid").contains("unknown mesh format"));
    assert!(load_err("z.ply.gz", b"not gzip").contains("gzip"));
    let e = format!("{:#}", TriangleMesh::load(Path::new("/nonexistent/dir/missing.ply")).unwrap_err());
    assert!(e.contains("missing.ply"), "{e}");
    // OBJ with an out-of-range face and with a NaN vertex.
    let e = load_err("bad.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    assert!(e.contains("bad.obj") && e.contains("line 4") && e.contains("out of range"), "{e}");
    let e = load_err("nan.obj", b"v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
    assert!(e.contains("nan.obj") && e.contains("line 2") && e.contains("vertex 2"), "{e}");
    // validate() on a hand-built mesh.
    let m = TriangleMesh { positions: vec![Vec3::ZERO; 3], normals: None, uvs: None, indices: vec![[0, 1, 3]] };
    assert!(format!("{:#}", m.validate().unwrap_err()).contains("face 0"));
}

/// An error from `parse_ply` as one line of text.
fn ply_err(bytes: &[u8]) -> String {
    let e = format!("{:#}", render::shape::mesh::parse_ply(bytes).expect_err("must fail"));
    assert!(!e.contains('\n'), "one line: {e}");
    e
}

/// A tetrahedron as ASCII PLY with the given vertex and face counts in the header and the
/// given body.
fn ascii_tet(nv: &str, nf: &str, body: &str) -> Vec<u8> {
    format!(
        "ply\nformat ascii 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {nf}\nproperty list uchar int vertex_indices\nend_header\n{body}"
    )
    .into_bytes()
}

const TET_VERTS: &str = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
const TET_FACES: &str = "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

/// The same tetrahedron as binary little-endian PLY.
fn binary_tet(nv: &str, nf: &str, verts: usize, faces: usize) -> Vec<u8> {
    let mut b = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    .into_bytes();
    let p = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for v in &p[..verts] {
        for c in v {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    for f in &[[0i32, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]][..faces] {
        b.push(3);
        for i in f {
            b.extend_from_slice(&i.to_le_bytes());
        }
    }
    b
}

#[test]
fn ply_tetrahedra_load() {
    let a = render::shape::mesh::parse_ply(&ascii_tet("4", "4", &format!("{TET_VERTS}{TET_FACES}"))).unwrap();
    let b = render::shape::mesh::parse_ply(&binary_tet("4", "4", 4, 4)).unwrap();
    assert_eq!(a, b);
    assert_eq!((a.positions.len(), a.indices.len()), (4, 4));
    // Blank lines, CRLF and trailing whitespace are fine.
    let crlf = format!("{TET_VERTS}\n{TET_FACES}\n  \n").replace('\n', "\r\n");
    assert_eq!(render::shape::mesh::parse_ply(&ascii_tet("4", "4", &crlf)).unwrap(), a);
    let mut padded = binary_tet("4", "4", 4, 4);
    padded.push(b'\n');
    assert_eq!(render::shape::mesh::parse_ply(&padded).unwrap(), b);
}

#[test]
fn ply_header_counts_beyond_the_data_are_refused_without_allocating() {
    // Counts of 2^31 − 1 (25 GB of vertices if reserved up front), 2^63 and usize::MAX over a
    // body of a few bytes: each must end in "end of file" at the first missing element.
    let body = format!("{TET_VERTS}{TET_FACES}");
    for big in ["2147483647", "9223372036854775808", "18446744073709551615"] {
        let e = ply_err(&ascii_tet(big, "4", &body));
        assert!(e.contains("line 14") && e.contains("vertex 4 of") && e.contains("too many"), "{e}");
        let e = ply_err(&ascii_tet("4", big, &body));
        assert!(e.contains("face 4 of") && e.contains("end of file"), "{e}");
        let e = ply_err(&binary_tet(big, "4", 4, 4));
        assert!(e.contains("vertex") && e.contains("byte") && e.contains("end of file"), "{e}");
        let e = ply_err(&binary_tet("4", big, 4, 4));
        assert!(e.contains("face 4 of") && e.contains("byte") && e.contains("end of file"), "{e}");
    }
    // The same through the gzip path of `TriangleMesh::load`.
    let d = tmp_dir("huge");
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(&binary_tet("2147483647", "4", 4, 4)).unwrap();
    let p = write(&d, "huge.ply.gz", &gz.finish().unwrap());
    let e = format!("{:#}", TriangleMesh::load(&p).unwrap_err());
    assert!(e.contains("huge.ply.gz") && e.contains("end of file"), "{e}");
    std::fs::remove_dir_all(&d).ok();
    // An element without properties cannot prove any count.
    let e = ply_err(b"ply\nformat binary_little_endian 1.0\nelement junk 9223372036854775807\nend_header\n");
    assert!(e.contains("junk") && e.contains("no properties"), "{e}");
    // A list length beyond the data.
    let e = ply_err(&ascii_tet("4", "1", &format!("{TET_VERTS}200 0 1 2\n")));
    assert!(e.contains("line 14") && e.contains("list length 200"), "{e}");
}

#[test]
fn ascii_ply_lines_must_match_the_header() {
    // A vertex line with 5 values for 3 properties (the data after it would shift).
    let e = ply_err(&ascii_tet("4", "4", &format!("0 0 0\n1 0 0 7 8\n0 1 0\n0 0 1\n{TET_FACES}")));
    assert!(e.contains("line 11") && e.contains("vertex 1 of 4") && e.contains("2 value(s) too many"), "{e}");
    // Too few values.
    let e = ply_err(&ascii_tet("4", "4", &format!("0 0 0\n1 0\n0 1 0\n0 0 1\n{TET_FACES}")));
    assert!(e.contains("line 11") && e.contains("too few values"), "{e}");
    // A header claiming 5 vertices over 4 lines: the first face line is not a vertex.
    let e = ply_err(&ascii_tet("5", "4", &format!("{TET_VERTS}{TET_FACES}")));
    assert!(e.contains("line 14") && e.contains("vertex 4 of 5"), "{e}");
    // Faces with 0, 1 and 2 indices.
    for (k, f) in ["0", "1 0", "2 0 1"].iter().enumerate() {
        let e = ply_err(&ascii_tet("4", "1", &format!("{TET_VERTS}{f}\n")));
        assert!(e.contains("line 14") && e.contains(&format!("{k} vertex indices")), "{e}");
    }
    // Junk after the last face, and a face more than the header declares.
    let e = ply_err(&ascii_tet("4", "4", &format!("{TET_VERTS}{TET_FACES}\nhello\n")));
    assert!(e.contains("line 19") && e.contains("after the last element"), "{e}");
    let e = ply_err(&ascii_tet("4", "3", &format!("{TET_VERTS}{TET_FACES}")));
    assert!(e.contains("line 17") && e.contains("after the last element"), "{e}");
    // A fractional or out-of-range integer, and a non-number.
    let e = ply_err(&ascii_tet("4", "1", &format!("{TET_VERTS}3 0 1.5 2\n")));
    assert!(e.contains("line 14") && e.contains("'1.5'"), "{e}");
    let e = ply_err(&ascii_tet("4", "1", &format!("{TET_VERTS}300 0 1 2\n")));
    assert!(e.contains("line 14") && e.contains("uchar"), "{e}");
    let e = ply_err(&ascii_tet("4", "1", &format!("0 0 0\n1 0 0\n0 x 0\n0 0 1\n3 0 1 2\n")));
    assert!(e.contains("line 12") && e.contains("'x'"), "{e}");
    // A non-finite normal.
    let n = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
             property float nx\nproperty float ny\nproperty float nz\nend_header\n0 0 0 0 inf 0\n";
    let e = ply_err(n.as_bytes());
    assert!(e.contains("line 11") && e.contains("non-finite normal"), "{e}");
}

#[test]
fn binary_ply_body_must_have_the_declared_size() {
    // A short vertex list: 4 declared, 3 present (the faces would be read as the 4th vertex).
    let e = ply_err(&binary_tet("4", "4", 3, 4));
    assert!(e.contains("byte"), "{e}");
    // Faces missing, and a face more than declared.
    let e = ply_err(&binary_tet("4", "4", 4, 3));
    assert!(e.contains("face 3 of 4") && e.contains("end of file"), "{e}");
    let e = ply_err(&binary_tet("4", "3", 4, 4));
    assert!(e.contains("byte") && e.contains("after the last element"), "{e}");
    // A face of two indices.
    let mut b = binary_tet("4", "1", 4, 0);
    b.push(2);
    b.extend_from_slice(&0i32.to_le_bytes());
    b.extend_from_slice(&1i32.to_le_bytes());
    let e = ply_err(&b);
    assert!(e.contains("face 0 of 1") && e.contains("2 vertex indices"), "{e}");
}

#[test]
fn ply_unknown_format_is_named_plainly() {
    let e = ply_err(b"ply\nformat ebcdic 1.0\nelement vertex 0\nend_header\n");
    assert!(e.contains("line 2") && e.contains("'ebcdic'") && !e.contains("Some("), "{e}");
    let e = ply_err(b"ply\nformat\nend_header\n");
    assert!(e.contains("line 2") && !e.contains("None"), "{e}");
}

#[test]
fn obj_errors_name_the_line() {
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    for (text, needle) in [
        (format!("{tri}v 1e39 0 0\nf 1 2 3\n"), "line 4"),
        (format!("{tri}vn 0 inf 1\nf 1 2 3\n"), "line 4"),
        (format!("{tri}v 1 1 1 0\nf 1 2 3\n"), "line 4"),
        (format!("{tri}f 1 2 0\n"), "line 4"),
        (format!("{tri}f 1 2 -4\n"), "line 4"),
        (format!("{tri}f 1 2 4294967299\n"), "line 4"),
        (format!("{tri}f 1 2 -9223372036854775808\n"), "line 4"),
        (format!("{tri}f 1 2\n"), "line 4"),
        (format!("{tri}f 1/1 2/1 3/1\n"), "texture coordinate index 1 out of range"),
        (format!("{tri}f 1//2 2//2 3//2\n"), "normal index 2 out of range"),
        (format!("{tri}f 1 2 x\n"), "line 4"),
        (format!("f 1 2 3\n{tri}"), "line 1"),
        (format!("{tri}vt 0\nf 1 2 3\n"), "line 4"),
    ] {
        let e = format!("{:#}", render::shape::mesh::parse_obj(text.as_bytes(), "t").expect_err(&text));
        assert!(e.contains(needle) && !e.contains('\n'), "{text:?}: {e}");
    }
    // Relative indices and a w coordinate are fine.
    let ok = render::shape::mesh::parse_obj(format!("{tri}v 2 2 2 2\nf -4 -3 -2\nf 1 2 4\n").as_bytes(), "t").unwrap();
    assert_eq!(ok[0].1.indices.len(), 2);
}

#[test]
fn shared_meshes_still_load() {
    // The full-resolution dragon lives in the shared data folder, next to the repository.
    let shared = repo().join("../shared/data/meshes");
    for (f, nv, nt) in [("dragon-871k.ply.gz", 437645, 871414), ("bunny.ply", 1839, 3674), ("dragon-48k.ply", 22998, 47794)] {
        let p = shared.join(f);
        if !p.exists() {
            eprintln!("skipping {}: not present", p.display());
            continue;
        }
        let m = load_one(&p);
        assert_eq!((m.positions.len(), m.indices.len()), (nv, nt), "{f}");
    }
    for f in ["scenes/meshes/tumbler.obj", "scenes/meshes/milk.obj", "crates/render/data/cornell-box/cbox_tri.obj"] {
        assert!(!TriangleMesh::load(&repo().join(f)).unwrap_or_else(|e| panic!("{e:#}")).is_empty(), "{f}");
    }
}
