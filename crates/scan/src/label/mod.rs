//! Micropolygon labelling (Stets et al., Applied Optics 56(27), 2017, §3: "the scanned geometry
//! is subdivided into micropolygons, each back-projected into the photograph and given the label
//! of the image segment it falls in"): the scanned mesh is diced until its triangles project to
//! about a pixel ([`subdivide`]), the photograph is segmented by edges and a marker-controlled
//! watershed and its regions grouped into K colour labels ([`segment`]), and each visible
//! micropolygon takes the label of the region its centroid projects into ([`backproject`]).
//! [`io`] reads meshes and photos and writes the labelled mesh, one mesh per label and the scene
//! that assigns one material per label. docs/labelling.md describes the whole.
//!
//! Frame and units: the mesh is in the calibration's camera frame (x right, y down, z forward;
//! the calibration's length unit, e.g. chessboard squares × `--square`), pixels in OpenCV's
//! convention (integer coordinates at pixel centres).

pub mod backproject;
pub mod board;
pub mod io;
pub mod normals;
pub mod segment;
pub mod subdivide;

use anyhow::{bail, Result};

use crate::calib::DeviceCalibration;
use crate::triangulate::Lens;
pub use segment::{Photo, SegmentOptions, Segmentation};
pub use subdivide::Mesh;

/// Options of [`label`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabelOptions {
    /// Longest projected edge of a micropolygon (pixels).
    pub max_edge_px: f64,
    /// Relative depth tolerance of the visibility test (module `backproject`).
    pub depth_tolerance: f64,
    /// Segmentation of the photo.
    pub segment: SegmentOptions,
}

impl Default for LabelOptions {
    fn default() -> Self {
        LabelOptions { max_edge_px: 1.5, depth_tolerance: 5e-3, segment: SegmentOptions::default() }
    }
}

/// The result of [`label`].
#[derive(Clone, Debug)]
pub struct Labelled {
    /// The micropolygons (camera frame, calibration units).
    pub mesh: Mesh,
    /// Per micropolygon: the triangle of the input mesh it came from.
    pub source: Vec<u32>,
    /// Per micropolygon: its label 0…K−1, or −1 where it is hidden or outside the image.
    pub face_label: Vec<i32>,
    /// Per micropolygon: the pixel (y·width + x) its centroid projects to, if inside the image.
    pub face_pixel: Vec<Option<u32>>,
    /// The photo's segmentation.
    pub segmentation: Segmentation,
    /// Micropolygons whose centroid projects outside the image.
    pub outside: usize,
    /// Micropolygons inside the image hidden by the depth test.
    pub occluded: usize,
    /// Micropolygons inside the image that passed the depth test but face away (back faces of a
    /// consistently wound mesh).
    pub back_faces: usize,
}

impl Labelled {
    /// Number of micropolygons of each label 0…K−1.
    pub fn faces_per_label(&self) -> Vec<usize> {
        let mut n = vec![0usize; self.segmentation.labels];
        for &l in &self.face_label {
            if l >= 0 {
                n[l as usize] += 1;
            }
        }
        n
    }
}

/// Labels `mesh` (camera frame) with the regions of `photo` seen by `camera` (module
/// documentation). Errors: a photo of another size than the calibrated camera's; no
/// micropolygon visible in the image (a mesh outside the camera's view).
pub fn label(mesh: &Mesh, photo: &Photo, camera: &DeviceCalibration, opts: &LabelOptions) -> Result<Labelled> {
    if (photo.width as u64, photo.height as u64) != (camera.width as u64, camera.height as u64) {
        bail!("the photo is {}x{} pixels but the calibrated camera is {}x{} (a calibration from another resolution)", photo.width, photo.height, camera.width, camera.height);
    }
    if mesh.triangles.is_empty() {
        bail!("the mesh has no faces");
    }
    let lens = Lens::new(camera, "camera")?;
    let sub = subdivide::subdivide(mesh, &lens, opts.max_edge_px)?;
    let vis = backproject::visibility(&sub.mesh, &lens, photo.width, photo.height, opts.depth_tolerance);
    if !vis.visible.iter().any(|&v| v) {
        bail!("no face of the mesh projects into the camera's {}x{} image (the mesh is outside the camera's view, or not in its frame)", camera.width, camera.height);
    }
    let edges = backproject::occlusion_edges(&vis.zbuf, photo.width, photo.height);
    let segmentation = segment::segment_with_barriers(photo, &opts.segment, Some(&edges))?;
    let map = segmentation.label_map();
    let face_label = backproject::assign(&vis, &segmentation.region, &segmentation.region_label, &map);
    let outside = vis.pixel.iter().filter(|p| p.is_none()).count();
    let back_faces = vis.back_faces;
    let occluded = vis.pixel.len() - outside - vis.visible.iter().filter(|&&v| v).count() - back_faces;
    Ok(Labelled { mesh: sub.mesh, source: sub.source, face_label, face_pixel: vis.pixel, segmentation, outside, occluded, back_faces })
}
