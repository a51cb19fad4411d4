//! Intel Open Image Denoise, found and loaded at run time (`dlopen`): a plain build of rift
//! needs no OIDN, and `--denoise` without it is a clear error that says how to install it.
//! Where the library is looked for, in order: `RIFT_OIDN_LIBRARY` (the file), the system's
//! library path (`libOpenImageDenoise.so.2`), and the `pyoidn` wheel of the `python3` on the
//! path (OIDN's official Linux binaries as published on PyPI).

use std::ffi::{CStr, CString, c_char, c_void};
use std::path::PathBuf;
use std::sync::OnceLock;

/// How to get the library, for the error a missing one gives.
pub const INSTALL_HINT: &str = "install Intel Open Image Denoise 2 (`python3 -m pip install \
     pyoidn` brings its official Linux binaries), or point RIFT_OIDN_LIBRARY at \
     libOpenImageDenoise.so.2";

/// The OIDN 2 entry points rift calls.
struct Api {
    new_device: unsafe extern "C" fn(i32) -> *mut c_void,
    set_device_int: unsafe extern "C" fn(*mut c_void, *const c_char, i32),
    commit_device: unsafe extern "C" fn(*mut c_void),
    release_device: unsafe extern "C" fn(*mut c_void),
    device_error: unsafe extern "C" fn(*mut c_void, *mut *const c_char) -> i32,
    new_filter: unsafe extern "C" fn(*mut c_void, *const c_char) -> *mut c_void,
    #[allow(clippy::type_complexity)]
    set_shared_image: unsafe extern "C" fn(
        *mut c_void,
        *const c_char,
        *mut c_void,
        i32,
        usize,
        usize,
        usize,
        usize,
        usize,
    ),
    set_filter_bool: unsafe extern "C" fn(*mut c_void, *const c_char, bool),
    set_filter_int: unsafe extern "C" fn(*mut c_void, *const c_char, i32),
    commit_filter: unsafe extern "C" fn(*mut c_void),
    execute_filter: unsafe extern "C" fn(*mut c_void),
    release_filter: unsafe extern "C" fn(*mut c_void),
}

const DEVICE_CPU: i32 = 1;
const FORMAT_FLOAT3: i32 = 3;

/// OIDN's filter quality.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    /// Final frames (OIDN's default for the ray-tracing filter).
    High,
    Balanced,
    /// Interactive previews.
    Fast,
}

impl Quality {
    fn code(self) -> i32 {
        match self {
            Quality::High => 6,
            Quality::Balanced => 5,
            Quality::Fast => 4,
        }
    }
}

/// The loaded library, once per process; `Err` says why it could not be.
fn api() -> Result<&'static Api, String> {
    static API: OnceLock<Result<Api, String>> = OnceLock::new();
    API.get_or_init(load).as_ref().map_err(Clone::clone)
}

/// Loads OIDN now, or says why it cannot be.
pub fn ensure_loaded() -> Result<(), String> {
    api().map(|_| ())
}

#[cfg(target_os = "linux")]
fn load() -> Result<Api, String> {
    let mut tried = Vec::new();
    let candidates = candidates();
    for candidate in &candidates {
        let name = CString::new(candidate.as_os_str().as_encoded_bytes())
            .map_err(|_| format!("{}: not a path", candidate.display()))?;
        // SAFETY: dlopen with a NUL-terminated name; the handle is kept for the process.
        let handle = unsafe { libc::dlopen(name.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
        if handle.is_null() {
            tried.push(candidate.display().to_string());
            continue;
        }
        return symbols(handle).map_err(|e| format!("{}: {e}", candidate.display()));
    }
    Err(format!(
        "Open Image Denoise was not found (looked for {}); {INSTALL_HINT}",
        tried.join(", ")
    ))
}

#[cfg(not(target_os = "linux"))]
fn load() -> Result<Api, String> {
    Err(format!(
        "denoising is built for Linux only so far; {INSTALL_HINT}"
    ))
}

/// Where the library may be, in the order tried.
fn candidates() -> Vec<PathBuf> {
    if let Some(path) = std::env::var_os("RIFT_OIDN_LIBRARY") {
        return vec![PathBuf::from(path)];
    }
    let mut out = vec![PathBuf::from("libOpenImageDenoise.so.2")];
    out.extend(pyoidn_library());
    out
}

/// The library inside the `pyoidn` package of the `python3` on the path, if it has one.
fn pyoidn_library() -> Option<PathBuf> {
    let script = "import os, pyoidn; print(os.path.dirname(pyoidn.__file__))";
    let out = std::process::Command::new("python3")
        .args(["-c", script])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()?;
    let folder = String::from_utf8(out.stdout).ok()?;
    let library = PathBuf::from(folder.trim()).join("oidn/lib/libOpenImageDenoise.so.2");
    (out.status.success() && library.is_file()).then_some(library)
}

#[cfg(target_os = "linux")]
fn symbols(handle: *mut c_void) -> Result<Api, String> {
    /// The function `name` of the library at `handle`, as the function pointer type `F`.
    fn symbol<F: Copy>(handle: *mut c_void, name: &CStr) -> Result<F, String> {
        assert_eq!(
            size_of::<F>(),
            size_of::<*mut c_void>(),
            "not a function pointer"
        );
        // SAFETY: dlsym on a live handle with a NUL-terminated name.
        let p = unsafe { libc::dlsym(handle, name.as_ptr()) };
        if p.is_null() {
            return Err(format!(
                "it lacks {} (OIDN 2 is needed)",
                name.to_string_lossy()
            ));
        }
        // SAFETY: OIDN 2's C API declares this symbol with the signature `F` of its field.
        Ok(unsafe { std::mem::transmute_copy::<*mut c_void, F>(&p) })
    }
    Ok(Api {
        new_device: symbol(handle, c"oidnNewDevice")?,
        set_device_int: symbol(handle, c"oidnSetDeviceInt")?,
        commit_device: symbol(handle, c"oidnCommitDevice")?,
        release_device: symbol(handle, c"oidnReleaseDevice")?,
        device_error: symbol(handle, c"oidnGetDeviceError")?,
        new_filter: symbol(handle, c"oidnNewFilter")?,
        set_shared_image: symbol(handle, c"oidnSetSharedFilterImage")?,
        set_filter_bool: symbol(handle, c"oidnSetFilterBool")?,
        set_filter_int: symbol(handle, c"oidnSetFilterInt")?,
        commit_filter: symbol(handle, c"oidnCommitFilter")?,
        execute_filter: symbol(handle, c"oidnExecuteFilter")?,
        release_filter: symbol(handle, c"oidnReleaseFilter")?,
    })
}

/// A CPU device of OIDN's.
pub struct Device {
    api: &'static Api,
    raw: *mut c_void,
}

impl Device {
    /// A CPU device using `threads` threads (0: all).
    pub fn new(threads: usize) -> Result<Self, String> {
        let api = api()?;
        // SAFETY: the API's own constructor; checked for errors below.
        let raw = unsafe { (api.new_device)(DEVICE_CPU) };
        if raw.is_null() {
            return Err("Open Image Denoise could not make a CPU device".into());
        }
        let device = Self { api, raw };
        // SAFETY: a live device and a NUL-terminated parameter name.
        unsafe {
            (api.set_device_int)(raw, c"numThreads".as_ptr(), threads.min(1 << 16) as i32);
            (api.commit_device)(raw);
        }
        device.check()?;
        Ok(device)
    }

    /// The device's pending error, if any.
    fn check(&self) -> Result<(), String> {
        let mut message: *const c_char = std::ptr::null();
        // SAFETY: a live device; the message, when set, is a C string OIDN owns until the
        // next call on the device.
        let code = unsafe { (self.api.device_error)(self.raw, &mut message) };
        if code == 0 {
            return Ok(());
        }
        let text = match message.is_null() {
            true => String::new(),
            // SAFETY: non-null, NUL-terminated, read at once.
            false => unsafe { CStr::from_ptr(message) }
                .to_string_lossy()
                .into_owned(),
        };
        Err(format!("Open Image Denoise failed (error {code}): {text}"))
    }

    /// Runs the ray-tracing filter ("RT") on `color` (width × height, row-major) in place,
    /// with `albedo` and `normal` as auxiliary images when given, `clean_aux` when they are
    /// noise-free (prefiltered), `hdr` for radiance (not [0, 1] colours).
    pub fn filter(&self, images: Images<'_>, settings: Settings) -> Result<(), String> {
        let Images {
            color,
            albedo,
            normal,
            size,
        } = images;
        sized("color", color, size)?;
        albedo.map_or(Ok(()), |a| sized("albedo", a, size))?;
        normal.map_or(Ok(()), |n| sized("normal", n, size))?;
        let out = color.as_mut_ptr().cast::<c_void>();
        let mut bound = vec![(c"color", out), (c"output", out)];
        bound.extend(albedo.map(|a| (c"albedo", a.as_ptr().cast_mut().cast())));
        bound.extend(normal.map(|n| (c"normal", n.as_ptr().cast_mut().cast())));
        self.run(&bound, size, settings)
    }

    /// Cleans an auxiliary image (`name`: "albedo" or "normal") in place: the RT filter with
    /// that image alone as input and output, as OIDN prescribes before `cleanAux`.
    pub fn prefilter(
        &self,
        name: &str,
        image: &mut [glam::Vec3],
        size: (usize, usize),
        quality: Quality,
    ) -> Result<(), String> {
        sized(name, image, size)?;
        let name = CString::new(name).map_err(|_| format!("{name}: not an image name"))?;
        let out = image.as_mut_ptr().cast::<c_void>();
        let settings = Settings {
            hdr: false,
            clean_aux: false,
            quality,
        };
        self.run(&[(&name, out), (c"output", out)], size, settings)
    }

    /// One execution of the RT filter on the images `bound` by name, each `size` packed float
    /// triples that outlive the call.
    fn run(
        &self,
        bound: &[(&CStr, *mut c_void)],
        (width, height): (usize, usize),
        settings: Settings,
    ) -> Result<(), String> {
        // SAFETY: a live device and a NUL-terminated filter type.
        let filter = unsafe { (self.api.new_filter)(self.raw, c"RT".as_ptr()) };
        if filter.is_null() {
            self.check()?;
            return Err("Open Image Denoise has no RT filter".into());
        }
        let stride = size_of::<glam::Vec3>();
        // SAFETY: a live filter; every image holds width × height packed float triples that
        // outlive its execution (the caller's borrows); NUL-terminated parameter names.
        unsafe {
            for &(name, image) in bound {
                (self.api.set_shared_image)(
                    filter,
                    name.as_ptr(),
                    image,
                    FORMAT_FLOAT3,
                    width,
                    height,
                    0,
                    stride,
                    stride * width,
                );
            }
            if bound.iter().any(|(name, _)| *name == c"color") {
                (self.api.set_filter_bool)(filter, c"hdr".as_ptr(), settings.hdr);
                (self.api.set_filter_bool)(filter, c"cleanAux".as_ptr(), settings.clean_aux);
            }
            (self.api.set_filter_int)(filter, c"quality".as_ptr(), settings.quality.code());
            (self.api.commit_filter)(filter);
            (self.api.execute_filter)(filter);
            (self.api.release_filter)(filter);
        }
        self.check()
    }
}

/// Refuses an image `name` that does not hold `size` pixels (OIDN would read past it).
fn sized(name: &str, image: &[glam::Vec3], (width, height): (usize, usize)) -> Result<(), String> {
    match image.len() == width * height {
        true => Ok(()),
        false => Err(format!(
            "a {name} image of the wrong size for {width}x{height}"
        )),
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: the device was made by this API and is released once.
        unsafe { (self.api.release_device)(self.raw) }
    }
}

/// The images one filter run reads: `color` is denoised in place.
pub struct Images<'a> {
    pub color: &'a mut [glam::Vec3],
    pub albedo: Option<&'a [glam::Vec3]>,
    pub normal: Option<&'a [glam::Vec3]>,
    pub size: (usize, usize),
}

/// How one filter run treats its images.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    pub hdr: bool,
    pub clean_aux: bool,
    pub quality: Quality,
}
