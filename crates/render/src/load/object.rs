//! `[[objects]]`: spheres, quads, disks, cylinders and meshes with their transforms, materials
//! and media, and the scene's length unit.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::type_complexity)]

use crate::load::desc::{CylinderDesc, DiskDesc, SceneDesc, TransformDesc};
use crate::load::error::{quote, quote_list, short, Cx};
use crate::load::medium::medium_desc;
use crate::load::spectrum::{as_f64, as_f64_array};
use crate::load::Build;
use crate::material::Material;
use crate::scene::ObjectInfo;
use crate::shape::mesh::TriangleMesh;
use crate::shape::sphere::Sphere;
use crate::shape::{tessellate, Shape};
use anyhow::Result;
use glam::{DVec3, Mat4, Vec3};
use std::ops::Range;

pub(crate) fn unit_in_metres(u: &str) -> Option<f64> {
    Some(match u {
        "m" => 1.0,
        "dm" => 0.1,
        "cm" => 0.01,
        "mm" => 1e-3,
        "um" | "µm" => 1e-6,
        "km" => 1e3,
        "in" => 0.0254,
        "ft" => 0.3048,
        _ => return None,
    })
}

/// Largest coordinate (m) of the scene's geometry after its unit and transform: squared distances
/// between points of the scene (up to 3·(2·10¹⁸ m)² ≈ 1.2·10³⁷ m²) then stay finite in f32, whose
/// largest value is 3.4·10³⁸. Geometry beyond it is refused at load.
pub const MAX_COORDINATE_M: f32 = 1e18;

/// Why a shape (in metres) lies outside ±[`MAX_COORDINATE_M`], if it does (NaN counts as outside).
pub(crate) fn out_of_range(shape: &Shape) -> Option<String> {
    let inside = |x: f32| x.abs() <= MAX_COORDINATE_M;
    match shape {
        Shape::Sphere(s) => {
            let reach = s.center.abs().max_element() + s.radius;
            (!(inside(reach) && s.radius.is_finite())).then(|| format!("the sphere reaches beyond ±{MAX_COORDINATE_M:e} m"))
        }
        Shape::Mesh(m) => m.positions.iter().position(|p| !p.to_array().into_iter().all(inside)).map(|i| {
            format!("vertex {i} at {:?} m lies beyond ±{MAX_COORDINATE_M:e} m", m.positions[i].to_array())
        }),
    }
}

pub(crate) fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

pub(crate) fn finite3(a: &[f64; 3]) -> bool {
    a.iter().all(|x| x.is_finite())
}

pub(crate) fn transform_matrix(cx: &Cx, span: &Range<usize>, field: &str, t: &TransformDesc) -> Result<Mat4> {
    if let Some(m) = &t.matrix {
        if t.scale.is_some() || t.rotate.is_some() || t.translate.is_some() {
            return Err(cx.err(span, field, "give either matrix or scale/rotate/translate, not both"));
        }
        if m.iter().flatten().any(|x| !x.is_finite()) {
            return Err(cx.err(span, &format!("{field}.matrix"), "entries must be finite"));
        }
        if m[3] != [0.0, 0.0, 0.0, 1.0] {
            return Err(cx.err(span, &format!("{field}.matrix"), format!("last row must be [0, 0, 0, 1] (an affine transform), got {:?}", m[3])));
        }
        // Rows as written (row-major), acting on column vectors.
        let rows: Vec<[f32; 4]> = m.iter().map(|r| [r[0] as f32, r[1] as f32, r[2] as f32, r[3] as f32]).collect();
        let mat = Mat4::from_cols_array_2d(&[rows[0], rows[1], rows[2], rows[3]]).transpose();
        if mat.determinant().abs() < 1e-12 {
            return Err(cx.err(span, &format!("{field}.matrix"), "is singular"));
        }
        return Ok(mat);
    }
    let mut m = Mat4::IDENTITY;
    if let Some(s) = &t.scale {
        let sv = if let Some(x) = as_f64(s) {
            Vec3::splat(x as f32)
        } else if let Some(a) = as_f64_array(s).filter(|a| a.len() == 3) {
            Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
        } else {
            return Err(cx.err(span, &format!("{field}.scale"), "must be a number or [sx, sy, sz]"));
        };
        if !sv.is_finite() || sv.x * sv.y * sv.z == 0.0 {
            return Err(cx.err(span, &format!("{field}.scale"), "must be finite and non-zero"));
        }
        m = Mat4::from_scale(sv) * m;
    }
    if let Some(r) = &t.rotate {
        let axis = Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32);
        if !(axis.length() > 0.0) || !axis.is_finite() || !r[3].is_finite() {
            return Err(cx.err(span, &format!("{field}.rotate"), "must be [axis_x, axis_y, axis_z, angle_deg] with a non-zero axis"));
        }
        m = Mat4::from_axis_angle(axis.normalize(), (r[3] as f32).to_radians()) * m;
    }
    if let Some(tr) = &t.translate {
        if !finite3(tr) {
            return Err(cx.err(span, &format!("{field}.translate"), "must be finite"));
        }
        m = Mat4::from_translation(v3(*tr)) * m;
    }
    Ok(m)
}

/// A required point or direction of a shape: present and finite.
fn point(cx: &Cx, span: &Range<usize>, field: &str, p: &Option<[f64; 3]>) -> Result<DVec3> {
    match p {
        None => Err(cx.err(span, field, "missing")),
        Some(a) if !finite3(a) => Err(cx.err(span, field, format!("must be finite, got {a:?}"))),
        Some(a) => Ok(DVec3::from_array(*a)),
    }
}

/// A required radius: present, positive and finite.
fn radius(cx: &Cx, span: &Range<usize>, field: &str, r: Option<f64>) -> Result<f64> {
    match r {
        None => Err(cx.err(span, field, "missing")),
        Some(r) if !(r > 0.0) || !r.is_finite() => Err(cx.err(span, field, format!("must be positive and finite, got {r}"))),
        Some(r) => Ok(r),
    }
}

/// The mesh of `disk = { center, normal, radius }` (in the file's unit, before the transform).
fn disk_mesh(cx: &Cx, span: &Range<usize>, field: &str, d: &DiskDesc) -> Result<TriangleMesh> {
    let center = point(cx, span, &format!("{field}.center"), &d.center)?;
    let normal = point(cx, span, &format!("{field}.normal"), &d.normal)?;
    let r = radius(cx, span, &format!("{field}.radius"), d.radius)?;
    let len = normal.length();
    if !(len > 0.0 && len.is_finite()) {
        return Err(cx.err(span, &format!("{field}.normal"), format!("must be a non-zero vector of finite length, got {:?}", normal.to_array())));
    }
    Ok(tessellate::disk(center, normal, r))
}

/// The mesh of `cylinder = { p0, p1, radius }` (in the file's unit, before the transform).
fn cylinder_mesh(cx: &Cx, span: &Range<usize>, field: &str, c: &CylinderDesc) -> Result<TriangleMesh> {
    let p0 = point(cx, span, &format!("{field}.p0"), &c.p0)?;
    let p1 = point(cx, span, &format!("{field}.p1"), &c.p1)?;
    let r = radius(cx, span, &format!("{field}.radius"), c.radius)?;
    let len = (p1 - p0).length();
    if !(len > 0.0) {
        return Err(cx.err(span, &format!("{field}.p1"), format!("must differ from p0 (the axis p0 → p1 has zero length): both are {:?}", p0.to_array())));
    }
    if !len.is_finite() {
        return Err(cx.err(span, &format!("{field}.p1"), "the axis p0 → p1 is too long (its length overflows)"));
    }
    Ok(tessellate::cylinder(p0, p1, r))
}

pub(crate) fn merge_meshes(list: Vec<TriangleMesh>) -> TriangleMesh {
    let all_normals = list.iter().all(|m| m.normals.is_some());
    let all_uvs = list.iter().all(|m| m.uvs.is_some());
    let mut out = TriangleMesh {
        positions: Vec::new(),
        normals: if all_normals { Some(Vec::new()) } else { None },
        uvs: if all_uvs { Some(Vec::new()) } else { None },
        indices: Vec::new(),
    };
    for m in list {
        let off = out.positions.len() as u32;
        out.indices.extend(m.indices.iter().map(|t| [t[0] + off, t[1] + off, t[2] + off]));
        out.positions.extend_from_slice(&m.positions);
        if let (Some(dst), Some(src)) = (out.normals.as_mut(), m.normals.as_ref()) {
            dst.extend_from_slice(src);
        }
        if let (Some(dst), Some(src)) = (out.uvs.as_mut(), m.uvs.as_ref()) {
            dst.extend_from_slice(src);
        }
    }
    out
}

/// The `[[objects]]`: their shapes (in metres), material links and interior media, with the
/// global `medium` first among the media.
pub(crate) fn objects(
    b: &mut Build,
    desc: &SceneDesc,
    materials: &[Material],
    material_names: &[String],
    mapped: &[bool],
) -> Result<(Vec<Shape>, Vec<ObjectInfo>, Vec<crate::medium::Medium>, Option<u32>)> {
    let (cx, files, unit_m) = (b.cx, b.files, b.unit_m);
    let sp = &b.sp;
    let hash = &mut b.hash;
    let unit_mat = Mat4::from_scale(Vec3::splat(unit_m as f32));
    let mut shapes = Vec::new();
    let mut objects: Vec<ObjectInfo> = Vec::new();
    let mut media = Vec::new();
    let global_medium = match &desc.medium {
        Some(v) => {
            media.push(medium_desc(cx, &sp, v, "medium", unit_m)?);
            Some(0u32)
        }
        None => None,
    };
    for (k, o) in desc.objects.iter().enumerate() {
        let span = o.span();
        let o = o.get_ref();
        let name = o.name.clone().unwrap_or_else(|| format!("object{k}"));
        let field = format!("objects[{k}] ({})", short(&name));
        if objects.iter().any(|x| x.name == name) {
            return Err(cx.err(&span, &format!("{field}.name"), "duplicate object name"));
        }
        let material = material_names.iter().position(|n| *n == o.material).ok_or_else(|| {
            cx.err(&span, &format!("{field}.material"), format!("unknown material {} (defined: {})", quote(&o.material), quote_list(material_names)))
        })? as u32;
        let given = [o.mesh.is_some(), o.quad.is_some(), o.quads.is_some(), o.sphere.is_some(), o.disk.is_some(), o.cylinder.is_some()]
            .iter()
            .filter(|b| **b)
            .count();
        if given != 1 {
            return Err(cx.err(&span, &field, "give exactly one shape: mesh, quad, quads, sphere, disk or cylinder"));
        }
        if o.group.is_some() && o.mesh.is_none() {
            return Err(cx.err(&span, &format!("{field}.group"), "only allowed with mesh"));
        }
        let xf = match &o.transform {
            Some(t) => transform_matrix(cx, &span, &format!("{field}.transform"), t)?,
            None => Mat4::IDENTITY,
        };
        let m = unit_mat * xf;
        let shape = if let Some(s) = &o.sphere {
            if !(s.radius > 0.0) || !s.radius.is_finite() {
                return Err(cx.err(&span, &format!("{field}.sphere.radius"), format!("must be positive, got {}", s.radius)));
            }
            if !finite3(&s.center) {
                return Err(cx.err(&span, &format!("{field}.sphere.center"), "must be finite"));
            }
            let (scale, _, _) = xf.to_scale_rotation_translation();
            if (scale.x - scale.y).abs() > 1e-5 * scale.x.abs() || (scale.x - scale.z).abs() > 1e-5 * scale.x.abs() {
                return Err(cx.err(&span, &format!("{field}.transform"), "a sphere allows only uniform scaling"));
            }
            let center = m.transform_point3(v3(s.center));
            let radius = (s.radius as f32) * scale.x.abs() * unit_m as f32;
            Shape::Sphere(Sphere { center, radius })
        } else {
            let mut mesh = if let Some(q) = &o.quad {
                if q.iter().any(|p| !finite3(p)) {
                    return Err(cx.err(&span, &format!("{field}.quad"), "corners must be finite"));
                }
                TriangleMesh::quad([v3(q[0]), v3(q[1]), v3(q[2]), v3(q[3])])
            } else if let Some(qs) = &o.quads {
                if qs.is_empty() {
                    return Err(cx.err(&span, &format!("{field}.quads"), "is empty"));
                }
                if qs.iter().flatten().any(|p| !finite3(p)) {
                    return Err(cx.err(&span, &format!("{field}.quads"), "corners must be finite"));
                }
                merge_meshes(qs.iter().map(|q| TriangleMesh::quad([v3(q[0]), v3(q[1]), v3(q[2]), v3(q[3])])).collect())
            } else if let Some(d) = &o.disk {
                disk_mesh(cx, &span, &format!("{field}.disk"), d)?
            } else if let Some(c) = &o.cylinder {
                cylinder_mesh(cx, &span, &format!("{field}.cylinder"), c)?
            } else {
                let rel = o.mesh.as_ref().unwrap();
                let (list, bytes) = files.load_mesh(rel).map_err(|e| cx.err(&span, &format!("{field}.mesh"), format!("{e:#}")))?;
                hash.write(&bytes);
                match &o.group {
                    Some(g) => {
                        let names: Vec<String> = list.iter().map(|(n, _)| n.clone()).collect();
                        let found: Vec<TriangleMesh> = list.into_iter().filter(|(n, _)| n == g).map(|(_, m)| m).collect();
                        if found.is_empty() {
                            return Err(cx.err(&span, &format!("{field}.group"), format!("{} has no group {} (groups: {})", short(rel), quote(g), quote_list(&names))));
                        }
                        merge_meshes(found)
                    }
                    None => merge_meshes(list.into_iter().map(|(_, m)| m).collect()),
                }
            };
            mesh.transform(&m);
            mesh.validate().map_err(|e| cx.err(&span, &field, format!("{e:#}")))?;
            if mesh.indices.is_empty() {
                return Err(cx.err(&span, &field, "mesh has no triangles"));
            }
            if mesh.uvs.is_none() && materials[material as usize].is_textured() {
                return Err(cx.err(&span, &format!("{field}.mesh"), format!("material `{}` is textured but the mesh has no texture coordinates (OBJ vt, PLY u/v)", o.material)));
            }
            if mesh.uvs.is_none() && mapped.get(material as usize).copied().unwrap_or(false) {
                return Err(cx.err(&span, &format!("{field}.mesh"), format!("material `{}` has a normal or bump map or a textured opacity but the mesh has no texture coordinates (OBJ vt, PLY u/v)", o.material)));
            }
            let translucent = matches!(materials[material as usize], Material::Translucent(_));
            if o.medium.is_some() || translucent {
                // A medium boundary (or translucent object) must be closed; orient it outwards (the front face is the outside).
                let what = if translucent { "material (translucent)" } else { "medium" };
                let open = if o.disk.is_some() { Some("disk") } else if o.cylinder.is_some() { Some("cylinder") } else { None };
                if let Some(shape) = open {
                    return Err(cx.err(&span, &format!("{field}.{what}"), format!("a {shape} is an open surface and cannot bound a volume (use a closed mesh)")));
                }
                let volume = crate::medium::closed_mesh_volume(&mesh).map_err(|e| cx.err(&span, &format!("{field}.{what}"), format!("boundary is not a closed mesh: {e:#}")))?;
                if volume < 0.0 {
                    for t in mesh.indices.iter_mut() {
                        t.swap(1, 2);
                    }
                    if let Some(ns) = mesh.normals.as_mut() {
                        for n in ns.iter_mut() {
                            *n = -*n;
                        }
                    }
                }
            }
            Shape::Mesh(mesh)
        };
        if let Some(why) = out_of_range(&shape) {
            let written = match &o.sphere {
                Some(s) => format!(" (center {:?}, radius {} as written)", s.center, s.radius),
                None => String::new(),
            };
            return Err(cx.err(&span, &field, format!("{why}{written} after the unit and transform")));
        }
        if matches!(&materials[material as usize], Material::Translucent(t) if t.from_medium) && o.medium.is_none() {
            return Err(cx.err(&span, &format!("{field}.medium"), "missing (its translucent material takes the coefficients from the object's medium)"));
        }
        let interior_medium = match &o.medium {
            Some(v) => {
                let m = medium_desc(cx, &sp, v, &format!("{field}.medium"), unit_m)?;
                if m.density.is_some() && matches!(&materials[material as usize], Material::Translucent(t) if t.from_medium) {
                    return Err(cx.err(&span, &format!("{field}.medium.density"), "not with a translucent material that takes its coefficients from the medium (the BSSRDF needs a homogeneous medium)"));
                }
                media.push(m);
                Some((media.len() - 1) as u32)
            }
            None => None,
        };
        shapes.push(shape);
        objects.push(ObjectInfo { name, material, light: None, interior_medium });
    }

    Ok((shapes, objects, media, global_medium))
}
