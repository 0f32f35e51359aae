//! `--denoise`: Intel Open Image Denoise (OIDN) on the finished image, with the first-hit
//! albedo and shading normal AOVs as guides (the "RT" filter in HDR mode, as pbrt-v4's
//! `imgtool denoise` and Mitsuba 3's `OptixDenoiser` use their denoisers' guide layers).
//!
//! The library is opened at run time (`dlopen`), so building with the `denoise` feature needs
//! no OIDN headers or link step: the first of `$LUCENT_OIDN_LIBRARY`, `libOpenImageDenoise.so.2`,
//! `libOpenImageDenoise.so.1`, `libOpenImageDenoise.so` (`.dylib` on macOS) that loads is used.
//! The calls are those of OIDN's C API common to versions 1.x and 2.x: `oidnNewDevice`,
//! `oidnCommitDevice`, `oidnNewFilter`, `oidnSetSharedFilterImage`, `oidnSetFilterBool`
//! (2.x) or `oidnSetFilter1b` (1.x), `oidnCommitFilter`, `oidnExecuteFilter`,
//! `oidnGetDeviceError`, `oidnReleaseFilter` and `oidnReleaseDevice`.

use std::ffi::{c_char, c_void, CStr, CString};

use anyhow::{anyhow, bail, Result};
use render::film::Film;
use render::image_io::Image;

/// The environment variable naming the OIDN shared library to load.
pub const LIBRARY_ENV: &str = "LUCENT_OIDN_LIBRARY";

/// `OIDN_DEVICE_TYPE_DEFAULT`.
const DEVICE_TYPE_DEFAULT: i32 = 0;
/// `OIDN_FORMAT_FLOAT3`.
const FORMAT_FLOAT3: i32 = 3;
/// `OIDN_ERROR_NONE`.
const ERROR_NONE: i32 = 0;

type NewDevice = unsafe extern "C" fn(i32) -> *mut c_void;
type Handle = unsafe extern "C" fn(*mut c_void);
type NewFilter = unsafe extern "C" fn(*mut c_void, *const c_char) -> *mut c_void;
type SetImage = unsafe extern "C" fn(*mut c_void, *const c_char, *mut c_void, i32, usize, usize, usize, usize, usize);
type SetBool = unsafe extern "C" fn(*mut c_void, *const c_char, bool);
type GetError = unsafe extern "C" fn(*mut c_void, *mut *const c_char) -> i32;

/// The loaded library and the functions used from it. The library stays loaded for the rest
/// of the process (it is never closed: OIDN's thread pool may outlive the last call).
struct Oidn {
    path: String,
    new_device: NewDevice,
    commit_device: Handle,
    release_device: Handle,
    new_filter: NewFilter,
    set_image: SetImage,
    set_bool: SetBool,
    commit_filter: Handle,
    execute_filter: Handle,
    release_filter: Handle,
    get_error: GetError,
}

fn candidates() -> Vec<String> {
    if let Ok(p) = std::env::var(LIBRARY_ENV) {
        if !p.is_empty() {
            return vec![p];
        }
    }
    let names: [&str; 3] = if cfg!(target_os = "macos") {
        ["libOpenImageDenoise.2.dylib", "libOpenImageDenoise.1.dylib", "libOpenImageDenoise.dylib"]
    } else {
        ["libOpenImageDenoise.so.2", "libOpenImageDenoise.so.1", "libOpenImageDenoise.so"]
    };
    names.map(String::from).to_vec()
}

fn last_dl_error() -> String {
    // SAFETY: dlerror returns null or a NUL-terminated string owned by the C library.
    let e = unsafe { libc::dlerror() };
    if e.is_null() {
        "unknown error".into()
    } else {
        // SAFETY: non-null, NUL-terminated (above).
        unsafe { CStr::from_ptr(e) }.to_string_lossy().into_owned()
    }
}

/// The library, loaded on first use (once per process).
fn oidn() -> Result<&'static Oidn> {
    static LOADED: std::sync::OnceLock<std::result::Result<Oidn, String>> = std::sync::OnceLock::new();
    LOADED.get_or_init(|| Oidn::load().map_err(|e| format!("{e:#}"))).as_ref().map_err(|e| anyhow!("{e}"))
}

impl Oidn {
    fn load() -> Result<Oidn> {
        let names = candidates();
        let mut errors = Vec::new();
        for name in &names {
            let c = CString::new(name.as_str()).map_err(|_| anyhow!("{LIBRARY_ENV}: the path holds a NUL byte"))?;
            // SAFETY: dlopen with a valid C string; the result is checked for null.
            let handle = unsafe { libc::dlopen(c.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
            if handle.is_null() {
                errors.push(last_dl_error());
                continue;
            }
            return Oidn::bind(handle, name.clone());
        }
        let from_env = std::env::var(LIBRARY_ENV).map(|p| !p.is_empty()).unwrap_or(false);
        if from_env {
            bail!("--denoise: {LIBRARY_ENV}={}: cannot load Intel Open Image Denoise: {}", names[0], errors.join("; "));
        }
        bail!(
            "--denoise: Intel Open Image Denoise not found ({} not loadable); install OIDN 1.x or 2.x or set {LIBRARY_ENV} to its libOpenImageDenoise shared library",
            names.join(", ")
        )
    }

    fn bind(handle: *mut c_void, path: String) -> Result<Oidn> {
        let sym = |name: &str| -> Option<*mut c_void> {
            let c = CString::new(name).ok()?;
            // SAFETY: dlsym on a live handle with a valid C string; null is checked.
            let p = unsafe { libc::dlsym(handle, c.as_ptr()) };
            (!p.is_null()).then_some(p)
        };
        let need = |name: &str| sym(name).ok_or_else(|| anyhow!("--denoise: {path} has no `{name}`; is it Intel Open Image Denoise 1.x or 2.x?"));
        let bind = || -> Result<Oidn> {
            let set_bool = sym("oidnSetFilterBool").or_else(|| sym("oidnSetFilter1b")).ok_or_else(|| anyhow!("--denoise: {path} has neither `oidnSetFilterBool` nor `oidnSetFilter1b`"))?;
            // SAFETY: each pointer is the named OIDN C API function, whose signature the type states.
            unsafe {
                Ok(Oidn {
                    path: path.clone(),
                    new_device: std::mem::transmute::<*mut c_void, NewDevice>(need("oidnNewDevice")?),
                    commit_device: std::mem::transmute::<*mut c_void, Handle>(need("oidnCommitDevice")?),
                    release_device: std::mem::transmute::<*mut c_void, Handle>(need("oidnReleaseDevice")?),
                    new_filter: std::mem::transmute::<*mut c_void, NewFilter>(need("oidnNewFilter")?),
                    set_image: std::mem::transmute::<*mut c_void, SetImage>(need("oidnSetSharedFilterImage")?),
                    set_bool: std::mem::transmute::<*mut c_void, SetBool>(set_bool),
                    commit_filter: std::mem::transmute::<*mut c_void, Handle>(need("oidnCommitFilter")?),
                    execute_filter: std::mem::transmute::<*mut c_void, Handle>(need("oidnExecuteFilter")?),
                    release_filter: std::mem::transmute::<*mut c_void, Handle>(need("oidnReleaseFilter")?),
                    get_error: std::mem::transmute::<*mut c_void, GetError>(need("oidnGetDeviceError")?),
                })
            }
        };
        match bind() {
            Ok(o) => Ok(o),
            Err(e) => {
                // SAFETY: the handle is live and nothing from it is kept.
                unsafe { libc::dlclose(handle) };
                Err(e)
            }
        }
    }

    /// The device's pending error, if any.
    fn check(&self, device: *mut c_void, step: &str) -> Result<()> {
        let mut msg: *const c_char = std::ptr::null();
        // SAFETY: a live device and a valid out-pointer.
        let code = unsafe { (self.get_error)(device, &mut msg) };
        if code == ERROR_NONE {
            return Ok(());
        }
        let text = if msg.is_null() {
            String::new()
        } else {
            // SAFETY: OIDN returns a NUL-terminated message valid until the next call.
            unsafe { CStr::from_ptr(msg) }.to_string_lossy().into_owned()
        };
        bail!("--denoise: Intel Open Image Denoise ({}) failed at {step}: error {code} {text}", self.path)
    }

    /// Run the "RT" filter on `color` with `albedo` and `normal` guides (row-major RGB triples).
    fn run(&self, width: usize, height: usize, color: &mut [f32], albedo: &mut [f32], normal: &mut [f32]) -> Result<Vec<f32>> {
        let n = width * height * 3;
        assert!(color.len() == n && albedo.len() == n && normal.len() == n);
        let mut output = vec![0.0f32; n];
        let stride = 3 * std::mem::size_of::<f32>();
        // SAFETY: the C API is used as documented: a device, committed; a filter with four
        // shared images that outlive the execution (they are borrowed for this whole call);
        // both released before returning.
        unsafe {
            let device = (self.new_device)(DEVICE_TYPE_DEFAULT);
            if device.is_null() {
                bail!("--denoise: Intel Open Image Denoise ({}) could not create a device", self.path);
            }
            (self.commit_device)(device);
            let result = (|| {
                self.check(device, "creating the device")?;
                let filter = (self.new_filter)(device, c"RT".as_ptr());
                if filter.is_null() {
                    self.check(device, "creating the RT filter")?;
                    bail!("--denoise: Intel Open Image Denoise ({}) has no RT filter", self.path);
                }
                let images: [(&CStr, *mut f32); 4] = [
                    (c"color", color.as_mut_ptr()),
                    (c"albedo", albedo.as_mut_ptr()),
                    (c"normal", normal.as_mut_ptr()),
                    (c"output", output.as_mut_ptr()),
                ];
                for (name, ptr) in images {
                    (self.set_image)(filter, name.as_ptr(), ptr.cast(), FORMAT_FLOAT3, width, height, 0, stride, stride * width);
                }
                (self.set_bool)(filter, c"hdr".as_ptr(), true);
                (self.commit_filter)(filter);
                let committed = self.check(device, "committing the filter");
                if committed.is_ok() {
                    (self.execute_filter)(filter);
                }
                let executed = committed.and_then(|_| self.check(device, "filtering"));
                (self.release_filter)(filter);
                executed
            })();
            (self.release_device)(device);
            result?;
        }
        Ok(output)
    }
}

/// The film's image denoised with its albedo and normal AOVs as guides. The film must carry
/// both (`--denoise` adds them to the layout).
pub fn denoise(film: &Film) -> Result<Image> {
    let image = film.to_image();
    let extras = film.extra_channels();
    let take = |names: [&str; 3]| -> Result<Vec<f32>> {
        let chans: Vec<&Vec<f32>> = names
            .iter()
            .map(|n| extras.iter().find(|(name, _)| name == n).map(|(_, v)| v).ok_or_else(|| anyhow!("--denoise: the film has no `{n}` channel")))
            .collect::<Result<_>>()?;
        let n = chans[0].len();
        Ok((0..n).flat_map(|i| [chans[0][i], chans[1][i], chans[2][i]]).collect())
    };
    let mut albedo = take(["albedo.R", "albedo.G", "albedo.B"])?;
    let mut normal = take(["N.X", "N.Y", "N.Z"])?;
    // Guides in the ranges OIDN expects: albedo in [0, 1], normals in [-1, 1].
    for a in &mut albedo {
        *a = a.clamp(0.0, 1.0);
    }
    let mut color: Vec<f32> = image.rgb.iter().flat_map(|c| c.map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 })).collect();
    let oidn = oidn()?;
    let out = oidn.run(image.width as usize, image.height as usize, &mut color, &mut albedo, &mut normal)?;
    let rgb = out.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    Ok(Image { width: image.width, height: image.height, rgb })
}

/// Which library `--denoise` would load, for messages: the path that loads, or the error.
pub fn library() -> Result<String> {
    oidn().map(|o| o.path.clone())
}
