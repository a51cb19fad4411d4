//! The page's check render: the path tracer's view of the shot at a frame, from the camera as
//! the page has posed it, at a small size and a few samples per pixel, as a PNG. The page asks
//! again with more samples for a progressively cleaner image, so the artist sees the preview
//! and the final render agree.

use rift_render::Scene;
use rift_render::frame::passes::RenderOptions;
use rift_render::platform::oidn::Quality;
use rift_render::prepare::Prepared;
use rift_render::rift_fx::Shot;
use rift_render::rift_fx::rig::AnimatedTransform;
use rift_render::rift_fx::shot::pose::{self, Facing};
use rift_render::rift_fx::shot::schema::PoseSpec;

/// The most pixels and samples a check render takes.
const MAX_PIXELS: u32 = 1 << 20;
const MAX_SPP: u32 = 256;

/// What the page asks for.
pub struct Request {
    frame: i64,
    width: u32,
    height: u32,
    spp: u32,
    /// The camera's position and a point it looks at, when the page has moved it.
    pose: Option<([f64; 3], [f64; 3])>,
    /// Whether to denoise where Open Image Denoise loads (the default).
    denoise: bool,
}

impl Request {
    /// From `frame=F&width=W&height=H&spp=N[&position=x,y,z&look_at=x,y,z][&denoise=0|1]`.
    pub fn parse(query: &str, shot: &Shot) -> Result<Self, String> {
        let get = |key: &str| {
            query
                .split('&')
                .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('='))
        };
        let number = |key: &str, default: u32| -> Result<u32, String> {
            get(key).map_or(Ok(default), |v| {
                v.parse()
                    .map_err(|_| format!("{key}: expected a whole number, got {v:?}"))
            })
        };
        let frame = super::frame_param(query, shot)?;
        let (width, height, spp) = (
            number("width", 320)?,
            number("height", 180)?,
            number("spp", 4)?,
        );
        if width == 0 || height == 0 || width.saturating_mul(height) > MAX_PIXELS {
            return Err(format!("width x height: expected 1 to {MAX_PIXELS} pixels"));
        }
        if spp == 0 || spp > MAX_SPP {
            return Err(format!("spp: expected 1 to {MAX_SPP}"));
        }
        let point = |key: &str| -> Result<Option<[f64; 3]>, String> {
            let Some(v) = get(key) else { return Ok(None) };
            let parts: Vec<f64> = v.split(',').filter_map(|x| x.parse().ok()).collect();
            match parts[..] {
                [x, y, z] if parts.iter().all(|p| p.is_finite()) => Ok(Some([x, y, z])),
                _ => Err(format!("{key}: expected three numbers x,y,z, got {v:?}")),
            }
        };
        let pose = match (point("position")?, point("look_at")?) {
            (Some(p), Some(t)) => Some((p, t)),
            (None, None) => None,
            _ => return Err("position and look_at go together".into()),
        };
        let denoise = match get("denoise") {
            None | Some("1") => true,
            Some("0") => false,
            Some(v) => return Err(format!("denoise: expected 0 or 1, got {v:?}")),
        };
        Ok(Self {
            frame,
            width,
            height,
            spp,
            pose,
            denoise,
        })
    }
}

/// The scene a check render was built for, kept so the passes of one check (which differ
/// only in samples) build it once.
pub struct Built {
    view: View,
    prepared: Prepared,
}

/// What a check render's scene depends on: all of the request but its samples.
#[derive(PartialEq)]
struct View {
    frame: i64,
    width: u32,
    height: u32,
    pose: Option<([f64; 3], [f64; 3])>,
}

/// Renders the request as an sRGB PNG, reusing `built` when it is the same view, denoised
/// (at OIDN's fast quality, a preview's) unless the request says not to and where Open Image
/// Denoise can be loaded. Also says which: "fast", "off", or why it was not ("unavailable: …"),
/// for the page's status line.
pub fn render(
    shot: &Shot,
    request: &Request,
    built: &mut Option<Built>,
) -> Result<(Vec<u8>, String), String> {
    let view = View {
        frame: request.frame,
        width: request.width,
        height: request.height,
        pose: request.pose,
    };
    if built.as_ref().is_none_or(|b| b.view != view) {
        // The old scene goes before the new one is built, so two never coexist.
        *built = None;
        *built = Some(Built {
            view,
            prepared: build(shot, request)?,
        });
    }
    let prepared = &built.as_ref().expect("built just above").prepared;
    let mut image = rift_render::frame::render(prepared, &RenderOptions::new(request.spp));
    let loaded = || rift_render::platform::oidn::ensure_loaded();
    let denoised = match request.denoise.then(loaded) {
        None => "off".to_owned(),
        Some(Ok(())) => {
            rift_render::frame::denoise::denoise(&mut image, Quality::Fast, 0)?;
            "fast".to_owned()
        }
        // The reason's first clause (not found, or failed to load), without the paths tried.
        Some(Err(why)) => format!(
            "unavailable: {}",
            why.split([';', '(']).next().unwrap_or(&why).trim()
        ),
    };
    let png = rift_render::frame::film::encode_srgb_png(image.width, image.height, &image.rgb)?;
    Ok((png, denoised))
}

/// The shot's scene at the request's frame, size and camera pose, prepared.
fn build(shot: &Shot, request: &Request) -> Result<Prepared, String> {
    let mut shot = shot.clone();
    if let Some((position, look_at)) = request.pose {
        let spec = PoseSpec {
            position: Some(position),
            look_at: Some(look_at),
            ..PoseSpec::default()
        };
        let at = pose::pose("camera", &spec, Facing::NegativeZ).map_err(|e| e.to_string())?;
        shot.camera.transform = AnimatedTransform::constant(at);
    }
    shot.camera.projection.resolution = [request.width, request.height];
    let scene = Scene::load(&shot, request.frame).map_err(|e| e.to_string())?;
    Ok(Prepared::new(scene))
}
