//! The renderer's sections of the shot file (rift-fx keeps them as raw TOML).
//!
//! ```toml
//! [render]
//! spp = 64                      # samples per pixel
//! seed = 0
//! max_bounces = 16              # omit for unlimited (Russian roulette ends paths)
//! indirect_samples = 1          # branches a camera path splits into where it first scatters
//!                               # (1 to 16, default 1; not at a mirror or smooth glass), each a BSDF
//!                               # sample carrying 1/n of it, light sampled there once: more of each
//!                               # pixel sample spent on indirect light (Arnold's diffuse samples).
//!                               # Pays where bounce light is the noise (lit interiors); costs where
//!                               # the pixel's own dimensions are (edges, depth of field, motion
//!                               # blur). Past spp × n = 65536 the branches' sample points repeat
//! max_portal_depth = 8          # teleports in a row before the next scattering event (default 8);
//!                               # an opening met past the limit ends the path (black)
//! light_through_openings = true # light sampling also looks through openings (false: only BSDF
//!                               # sampling finds light through them; for A/B and as an escape)
//! guide_through_openings = false # true: bounces are aimed at openings where training paths found
//!                               # that light comes through them after bouncing beyond, and roulette
//!                               # follows dim pixels' paths into bright places (for sets lit by
//!                               # bounce light through openings; costs elsewhere)
//! denoise = false               # denoise finished frames with Open Image Denoise (the noisy
//!                               # beauty kept as the layer noisy.R/G/B); as `--denoise`
//! output = "out/shot.####.exr"  # frame number replaces the #s; relative to the working directory
//! rings = "cache/shot.####.ringcache"  # ring caches written by `rift fx` (relative to the shot
//!                               # file), or its point clouds: "cache/shot.%o.####.ply" (%o: the
//!                               # opening's name); omit to generate the rings in memory
//!
//! [[material]]
//! name = "white"
//! type = "diffuse"              # "diffuse", "conductor", "dielectric" or "standard"
//! reflectance = [0.8, 0.8, 0.8] # diffuse: albedo; conductor: colour at normal incidence; or a
//!                               # texture: { texture = "wood.png", scale = 1.0, offset = 0.0,
//!                               # colorspace = "srgb", filter = "trilinear" } (PNG, JPEG or
//!                               # EXR, relative to the shot file; 8-bit colours are sRGB
//!                               # unless "linear"; "bilinear" skips the mipmaps; the mesh
//!                               # must give UVs). `roughness` takes a texture too, read from
//!                               # one `channel` ("r", "g", "b" or "a"; linear by default).
//!                               # An OBJ's MTL brings map_Kd, map_Pr/map_Ns, map_Pm, norm
//! emission = [0.0, 0.0, 0.0]    # optional radiance, linear Rec.709, or a texture (an MTL's
//!                               # map_Ke): { texture = "screen.png", scale = 4.0 }
//! two_sided_emission = false
//! # normal_map = { texture = "n.png", scale = 1.0 }  # tangent-space, linear; scale: strength
//! # opacity = { texture = "leaf.png", channel = "a" }  # cut-outs: 0 lets rays through (or a
//!                               # number); objects that stand still only
//! one_sided = false             # true: the back side (against the winding's normal) absorbs
//!                               # all light, as Mitsuba's BSDFs do; the default reflects on both
//!
//! [[material]]
//! name = "brass"
//! type = "conductor"            # GGX microfacets
//! reflectance = [1.0, 0.78, 0.34] # Schlick Fresnel from this colour at normal incidence, or
//! # eta = [0.18, 0.42, 1.37]    # the exact Fresnel term of a complex index η + ik per channel
//! # k = [3.42, 2.35, 1.77]      # (both, each > 0), or
//! # metal = "gold"              # a measured metal: "gold", "silver", "copper", "aluminium"
//! roughness = 0.3               # 0 (mirror) to 1; α = roughness²
//! shadowing = "height-correlated" # GGX masking-shadowing (conductors and dielectrics);
//!                               # "separable" as Mitsuba 3 has it, darker at grazing angles
//! multiscatter = false          # conductors: add back the light of inter-facet bounces, which
//!                               # single-scattering GGX loses (12% at roughness 0.5, 59% at 1)
//!
//! [[material]]
//! name = "glass"
//! type = "dielectric"           # GGX reflection and refraction, exact Fresnel
//! ior = 1.5                     # inside (behind the front face) over outside
//! roughness = 0.0               # 0: a perfectly smooth interface
//! contact = "gap"               # where a face touches another object's in one plane (a glass
//!                               # on a table): "gap", the limit of an air gap closing (light
//!                               # leaves through the face, total internal reflection and
//!                               # all), or "optical": no air between, the face is not there
//!                               # and light inside meets the table directly, as a glass sunk
//!                               # into it by a hair (Mitsuba 3's tie-break)
//!
//! [[material]]
//! name = "lacquered_wood"
//! type = "standard"             # a diffuse base under a dielectric specular layer, blended
//!                               # with a metal, under an optional clear coat; energy-conserving
//! base_color = [0.5, 0.3, 0.2]  # the diffuse albedo, and the metal's colour
//! metallic = 0.0                # 0 dielectric to 1 metal
//! roughness = 0.4               # the specular layer's and the metal's (default 0.5)
//! ior = 1.5                     # the specular layer's, 1 to 3
//! specular_color = [1.0, 1.0, 1.0]  # tints the specular layer's reflection
//! coat = 0.0                    # the clear coat's weight, 0 to 1
//! coat_roughness = 0.0
//! coat_ior = 1.5
//!                               # every input but the two iors takes a texture
//!
//! [[medium]]                    # a homogeneous medium: haze, fog, smoke, ink
//! name = "haze"
//! # object = "fog_volume"       # inside this object's closed mesh (which stands still, is not
//!                               # drawn, needs no material and overlaps no other medium's box);
//!                               # without `object` the medium fills the rest of the scene (one such)
//! absorption = [0.01, 0.01, 0.01]  # σ_a per metre (each optional, default 0)
//! scattering = [0.05, 0.05, 0.05]  # σ_s per metre
//! anisotropy = 0.3              # Henyey–Greenstein g in (-1, 1): > 0 scatters forward
//! emission = [0.0, 0.0, 0.0]    # radiance emitted per metre of path
//!                               # (a medium filling the scene hides the sky: infinitely far)
//!
//! [[medium]]                    # a heterogeneous medium from an OpenVDB density grid
//! name = "smoke"
//! vdb = "smoke.####.vdb"        # relative to the shot file; a run of # is the frame number
//!                               # (float, double or half grids)
//! grid = "density"              # the grid's name in the file (default "density")
//! density = 2.0                 # a factor on its values (default 1)
//! absorption = [0.5, 0.5, 0.5]  # coefficients per metre at density 1, as above
//! scattering = [4.0, 4.0, 4.0]
//! anisotropy = 0.3
//! transform = { position = [0.0, 0.0, -3.0], scale = 0.5 }  # keyed like an object's (optional)
//! # through = "door"            # carried through this opening by the solver, like an object
//!
//! [[usd]]                       # the pipeline's set, characters, lights and materials
//! file = "set/room.usdc"        # usda, usdc or usdz, relative to the shot file; each mesh prim
//!                               # is an object named by its path ("/World/Room"), each bound
//!                               # UsdPreviewSurface a material named by its path, each UsdLux
//!                               # light a [[light]], a dome light the [environment] (docs/usd.md)
//! # root = "/World/Set"         # only the prims under this one
//! # time_offset = 0.0           # frames: time code t is shot frame t + time_offset
//!                               # An [[object]] named like a prim, without a mesh, changes that
//!                               # prim's object (material, transform, visibility, light group,
//!                               # through); a [[material]] named like a USD material replaces it
//!
//! [[light]]                     # a light as a lighter places it, in UsdLux's units
//! name = "key"
//! type = "rect"                 # "point" (a sphere: `radius`, 0 for a point), "spot" (a point
//!                               # or sphere with a cone), "rect", "disk" or "distant" (a sun)
//! color = [1.0, 0.9, 0.8]       # linear Rec. 709 (default white)
//! intensity = 10.0              # radiance: color × intensity × 2^exposure (default 1; a
//! exposure = 0.0                # distant light's default is 50000)
//! normalize = false             # true: divide by the emitting area (power stays as the size
//!                               # changes); a distant light's value is then its illuminance.
//!                               # A point (radius 0) or a sun of angle 0 is always normalised
//! width = 1.0                   # rect: along its local X (default 1)
//! height = 0.5                  # rect: along its local Y (default 1)
//! # radius = 0.05               # point or spot: the sphere's (default 0); disk (default 0.5)
//! # angle = 0.53                # distant: angular diameter in degrees (default 0.53)
//! # cone_angle = 30.0           # spot (or any point, disk or rect light): degrees from its −Z
//! # cone_softness = 0.2         # share of the cone over which emission fades (default 0)
//! transform = { position = [0.0, 2.9, 0.0], rotation_degrees = [-90.0, 0.0, 0.0] }
//!                               # rect, disk and spot lights emit along their local −Z, a sun
//!                               # shines along it; `look_at` aims it; keys move and blur it
//! visibility = { camera = false }  # which rays see it: camera and through_portal default to
//!                               # false (lights light the scene, the camera does not see
//!                               # them), indirect to true; no light blocks any ray
//! # light_group = "key"         # its light in the EXR layer lightgroup.key
//!
//! [environment]                # light from every direction where rays escape:
//! radiance = [0.2, 0.25, 0.3]   # a constant radiance, or
//! # map = "sky.exr"             # a lat-long EXR (RGB), relative to the shot file; top row up,
//! # intensity = 1.0             # middle column towards −Z; scaled by intensity and turned
//! # rotation_degrees = 0.0      # about +Y
//! # light_group = "sky"         # its light in its own EXR layer, lightgroup.sky (see below)
//!
//! [[object]]
//! name = "room"
//! mesh = "cornell.obj"          # OBJ (+MTL) or PLY, relative to the shot file; a run of # in
//!                               # the file name is a mesh sequence, one file per frame
//!                               # ("walker.####.ply"; "walker.0012.5.ply" a sub-frame sample):
//!                               # a deforming mesh, read around the times rays reach (the ends
//!                               # hold), every file of one topology; a PLY's vx vy vz (units
//!                               # per second) curve each vertex's path between samples
//! material = "white"            # optional: otherwise each OBJ group's `usemtl` name, looked up
//!                               # among [[material]] first and then in the MTL (Kd, Ke)
//! transform = { position = [0.0, 0.0, 0.0] }   # a pose as in rift-fx (optional), or keys:
//! # transform = { keys = [{ frame = 1, position = [0, 0, 0] }, { frame = 2, position = [1, 0, 0] }] }
//! # An object whose transform changes while the shutter is open is blurred along its motion
//! # (rays meet it at their own time); any other object is baked into world space.
//!
//! [[object]]
//! name = "ball_there"
//! copy_of = "ball"              # mesh, material and transform of an earlier object, unless given
//! through = "room_door"         # placed through this opening by the constraint solver: T·transform
//!                               # (an opening with a time offset shows it that much earlier)
//! # back_through = "room_door"  # instead, the inverse solver: the here-side copy of a there-
//!                               # side target, T⁻¹·transform (for rigs that reach through it)
//! [object.visibility]           # which rays see the object (each defaults to true)
//! camera = true                 # camera rays that have not passed an opening
//! through_portal = true         # camera rays after one or more openings, before any scattering
//! indirect = true               # rays after a scattering event
//! shadow = true                 # shadow rays: false casts no shadows
//! # light_group = "practicals"  # (on any [[object]]) the light its emissive parts give goes to
//!                               # the EXR layer lightgroup.practicals; emitters that name no
//!                               # group go to lightgroup.default, and the layers sum to the
//!                               # beauty (light through openings included). At most 7 groups;
//!                               # names of letters, digits and `_`.
//!
//! [camera.stereo]               # renders a left and a right image: off-axis (parallel) eyes
//! interaxial = 0.065            # meters between the eyes, along the camera's X
//! convergence = 4.0             # meters to the plane of zero parallax
//!
//! [camera.clip]                 # culls only camera rays that have not passed a portal
//! near = 0.1                    # depth along the view axis, meters
//! far = 100.0
//! planes = [[0.0, 0.0, -1.0, -2.0]]  # camera space [a, b, c, d]: keeps a·x + b·y + c·z + d ≥ 0
//! world_planes = [[0.0, 1.0, 0.0, 0.0]]  # the same in world space (stays put as the camera moves)
//!
//! [[portal]]                    # the opening itself: see rift-fx
//! [portal.surface]              # how the opening shades (all optional)
//! radius = 1.0                  # teleport region: a disk of this radius in the opening's frame
//!                               # (default: inside the ring's boundary at each ray's time, the
//!                               # strands' inner envelope; a disk of radius 1 without a ring)
//! rectangle = [0.9, 2.0]        # or a centred rectangle: width along local X, height along Y
//! polygon = [[0, 0], [1, 0], [0, 1]]  # or any simple polygon in local XY (one of the three)
//! tint = [1.0, 1.0, 1.0]        # scales what is seen through the opening
//! opacity = 1.0                 # 1: every ray teleports; 0: every ray passes through untouched
//! ior = 1.0                     # bends the teleported direction at the exit, like refraction
//! time_offset = 0.0             # frames: rays that pass see the there side this much later
//! [portal.surface.distortion]   # animated noise on the exit normal (bends only when ior ≠ 1)
//! amplitude = 0.05              # largest slope of the normal
//! frequency = 3.0               # features per unit of the opening's frame
//! evolution = 0.5               # noise units per second
//! seed = 0
//! [portal.surface.strands]      # the ring's strands: round curves emitting Cd · intensity
//! intensity = 1.0               # scales their emission (0: dark strands that still block)
//! visibility = { camera = true, through_portal = true, indirect = true, shadow = true }
//! # light_group = "ring"        # the ring's light in its own EXR layer, lightgroup.ring
//!
//! [[portal.cull]]               # hides linked objects where they poke out behind the opening
//! objects = ["ball"]            # [[object]] names
//! side = "here"                 # "here": behind the here opening; "there": behind its exit
//! depth = 2.0                   # how far behind, in the opening's units (default: no limit)
//! radius = 1.5                  # distance from the opening's axis (default: no limit)
//! ```

use serde::Deserialize;

/// One `[[usd]]` section.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UsdSection {
    /// The layer, relative to the shot file.
    pub file: String,
    /// Only the prims under this one (default: the whole stage).
    pub root: Option<String>,
    /// Frames added to the stage's times: time code `t` is shot frame `t + time_offset`
    /// (when the stage's time codes per second equal the shot's fps).
    pub time_offset: Option<f64>,
}

/// `[render]`.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct RenderSection {
    pub spp: Option<i64>,
    pub seed: Option<i64>,
    pub max_bounces: Option<i64>,
    pub indirect_samples: Option<i64>,
    pub max_portal_depth: Option<i64>,
    pub light_through_openings: Option<bool>,
    pub guide_through_openings: Option<bool>,
    pub denoise: Option<bool>,
    pub output: Option<String>,
    pub rings: Option<String>,
}

/// A texture as a material's input: `reflectance = { texture = "wood.png" }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextureSection {
    /// The image, relative to the shot file.
    pub texture: String,
    /// A factor on its values: a number, or a colour for a colour input (default 1).
    pub scale: Option<toml::Value>,
    /// Added after the scale (default 0).
    pub offset: Option<toml::Value>,
    /// How 8-bit values are encoded: "srgb" (default for colours) or "linear" (default for
    /// numbers); EXR is always linear.
    pub colorspace: Option<TextureColorSpace>,
    /// The channel a number is read from: "r" (default), "g", "b" or "a".
    pub channel: Option<String>,
    /// "trilinear" (default: the mipmap level the ray's footprint picks) or "bilinear" (the
    /// full image; the pixel's samples filter it).
    pub filter: Option<TextureFilter>,
}

/// `filter` of a texture.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum TextureFilter {
    Trilinear,
    Bilinear,
}

/// `colorspace` of a texture.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum TextureColorSpace {
    Srgb,
    Linear,
}

/// One `[[material]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSection {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: MaterialKind,
    pub reflectance: Option<[f64; 3]>,
    pub roughness: Option<f64>,
    pub ior: Option<f64>,
    pub eta: Option<[f64; 3]>,
    pub k: Option<[f64; 3]>,
    pub metal: Option<String>,
    pub shadowing: Option<ShadowingKind>,
    pub multiscatter: Option<bool>,
    pub emission: Option<[f64; 3]>,
    pub two_sided_emission: Option<bool>,
    pub one_sided: Option<bool>,
    /// Cut-outs: the share of rays the surface stops (0 to 1; a texture, usually "a").
    pub opacity: Option<f64>,
    /// The standard material's inputs.
    pub base_color: Option<[f64; 3]>,
    pub metallic: Option<f64>,
    pub specular_color: Option<[f64; 3]>,
    pub coat: Option<f64>,
    pub coat_roughness: Option<f64>,
    pub coat_ior: Option<f64>,
    /// How the surface touches another in one plane: "gap" (default) or "optical".
    pub contact: Option<ContactKind>,
}

/// One `[[medium]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumSection {
    pub name: String,
    pub object: Option<String>,
    pub absorption: Option<[f64; 3]>,
    pub scattering: Option<[f64; 3]>,
    pub anisotropy: Option<f64>,
    pub emission: Option<[f64; 3]>,
    /// An OpenVDB file whose grid scales the coefficients (a heterogeneous medium).
    pub vdb: Option<String>,
    /// The grid's name in `vdb` (default "density").
    pub grid: Option<String>,
    /// A factor on the grid's values (default 1).
    pub density: Option<f64>,
    /// Where the grid is (keyed like an object's transform).
    pub transform: Option<rift_fx::shot::schema::PoseSpec>,
    /// An opening the grid is carried through by the constraint solver.
    pub through: Option<String>,
}

/// `shadowing` of a rough conductor or dielectric.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum ShadowingKind {
    HeightCorrelated,
    Separable,
}

/// `contact` of a material: how its faces touch another object's in one plane.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ContactKind {
    /// The limit of an air gap closing: light leaves through the face to meet the other.
    Gap,
    /// No air between: where they touch the face is not there, and light inside meets the
    /// other surface directly.
    Optical,
}

/// Material types.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum MaterialKind {
    Diffuse,
    Conductor,
    Dielectric,
    Standard,
}

/// One `[[object]]`.
#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub struct ObjectSection {
    pub name: String,
    pub mesh: Option<String>,
    pub material: Option<String>,
    pub transform: Option<rift_fx::shot::schema::PoseSpec>,
    pub copy_of: Option<String>,
    pub through: Option<String>,
    pub back_through: Option<String>,
    pub visibility: Option<VisibilitySection>,
    pub light_group: Option<String>,
    /// The shape of an object a USD layer brings (never a shot-file key).
    #[serde(skip)]
    pub shape: Option<std::sync::Arc<super::mesh::Shape>>,
    /// Where a USD layer instances the shape (each instance's world placement, the shape and
    /// its BVH shared); empty for an object placed once (never a shot-file key).
    #[serde(skip)]
    pub instances: Vec<rift_fx::rig::AnimatedTransform>,
    /// The name of each of `instances` (its prim's path), which ID passes give it; empty when
    /// they go by the object's name (never a shot-file key).
    #[serde(skip)]
    pub instance_names: Vec<String>,
    /// Where a moving USD prim's keys start from (never a shot-file key).
    #[serde(skip)]
    pub stage_origin: StageOrigin,
}

/// A moving USD prim's points leave out where the stage puts it at its first sample, and its
/// keys put it there, so it turns about its own origin between samples. A shot-file
/// `transform` that replaces those keys (the prim's own section, or a copy's) places it from
/// that position, as it places a still prim from where the stage leaves it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub enum StageOrigin {
    /// Not a moving USD prim: `transform` applies to the points as they are.
    #[default]
    Included,
    /// Moving under the stage's own keys, which put it at this position at its first sample.
    Keyed([f64; 3]),
    /// Moving in USD, placed by a shot-file `transform` from this position.
    Replaced([f64; 3]),
}

impl StageOrigin {
    /// The same prim once a shot-file `transform` replaces its stage's keys.
    pub fn replaced(self) -> Self {
        match self {
            Self::Keyed(p) | Self::Replaced(p) => Self::Replaced(p),
            Self::Included => Self::Included,
        }
    }
}

/// `[object.visibility]`: which rays see the object (each defaults to true).
#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
pub struct VisibilitySection {
    pub camera: Option<bool>,
    pub through_portal: Option<bool>,
    pub indirect: Option<bool>,
    pub shadow: Option<bool>,
}

/// One `[[light]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSection {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: LightKind,
    pub color: Option<[f64; 3]>,
    pub intensity: Option<f64>,
    pub exposure: Option<f64>,
    pub normalize: Option<bool>,
    pub radius: Option<f64>,
    pub width: Option<f64>,
    pub height: Option<f64>,
    pub angle: Option<f64>,
    pub cone_angle: Option<f64>,
    pub cone_softness: Option<f64>,
    pub transform: Option<rift_fx::shot::schema::PoseSpec>,
    pub visibility: Option<VisibilitySection>,
    pub light_group: Option<String>,
}

/// The kinds of `[[light]]`.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum LightKind {
    Point,
    Spot,
    Rect,
    Disk,
    Distant,
}

/// One `[[portal.cull]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CullSection {
    pub objects: Vec<String>,
    pub side: Option<CullSide>,
    pub depth: Option<f64>,
    pub radius: Option<f64>,
}

/// Which side of an opening a cull volume lies behind.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum CullSide {
    /// Behind the here opening (local −Z).
    Here,
    /// Behind the exit (the there frame's local +Z).
    There,
}

/// `[environment]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentSection {
    pub radiance: Option<[f64; 3]>,
    pub map: Option<String>,
    pub intensity: Option<f64>,
    pub rotation_degrees: Option<f64>,
    pub light_group: Option<String>,
}

/// `[camera.stereo]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StereoSection {
    pub interaxial: f64,
    pub convergence: f64,
}

/// `[camera.clip]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipSection {
    pub near: Option<f64>,
    pub far: Option<f64>,
    pub planes: Option<Vec<[f64; 4]>>,
    pub world_planes: Option<Vec<[f64; 4]>>,
}

/// `[portal.surface]`.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct PortalSurfaceSection {
    pub radius: Option<f64>,
    pub rectangle: Option<[f64; 2]>,
    pub polygon: Option<Vec<[f64; 2]>>,
    pub tint: Option<[f64; 3]>,
    pub opacity: Option<f64>,
    pub ior: Option<f64>,
    pub distortion: Option<DistortionSection>,
    pub time_offset: Option<f64>,
    pub strands: Option<StrandsSection>,
}

/// `[portal.surface.strands]`: how the ring's strands render.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct StrandsSection {
    pub intensity: Option<f64>,
    pub visibility: Option<VisibilitySection>,
    pub light_group: Option<String>,
}

/// `[portal.surface.distortion]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DistortionSection {
    pub amplitude: f64,
    pub frequency: Option<f64>,
    pub evolution: Option<f64>,
    pub seed: Option<i64>,
}
