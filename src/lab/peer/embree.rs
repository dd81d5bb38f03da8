//! Embree 3 as a peer for the primary-shadow workload (issue 11, item 2a), behind the cargo
//! feature `embree` (links the system's libembree3; Debian: `libembree-dev`).
//!
//! The same rays as the native peer ([`super::native`]): the scene's primitives in f32 relative
//! to the eye, eye rays through pixel centres with the same camera basis, the same shadow-ray
//! origins (`offset_origin`) and end gap, the same Lambert shading, rows handed out one at a time
//! to `std::thread::scope` workers with one `RTCIntersectContext` per thread. Only finding the
//! hits differs: Embree's BVH (scene build quality HIGH, `RTC_SCENE_FLAG_ROBUST`, see
//! [`EmbreePeer::new`]) and its
//! single-ray kernels `rtcIntersect1` / `rtcOccluded1`, which is what the acceptance
//! (irt ≥ 0.5× Embree) compares with. With `packets` ([`EmbreePeer::with_options`], `irt bench
//! --peer embree-packet`) it traces eight pixels of a row at a time with `rtcIntersect8` /
//! `rtcOccluded8` instead, reported separately.
//!
//! Geometry: triangles as one `RTC_GEOMETRY_TYPE_TRIANGLE` (float3 vertices, uint3 indices, three
//! vertices per triangle so Embree's primitive ids are irt's triangle indices), spheres as one
//! `RTC_GEOMETRY_TYPE_SPHERE_POINT` (float4 x y z r). irt's cones are open (no caps), which
//! Embree's cone curves are not, so cones go through a user geometry
//! (`RTC_GEOMETRY_TYPE_USER`) whose intersect and occluded callbacks call the native peer's f32
//! cone test (the shader's): on cone scenes Embree's time includes that callback code, not an
//! Embree kernel. The hit point, normals and colours are then computed by the shared shading
//! from the primitive and Embree's t and barycentrics, so an image differs from the native
//! peer's only where the two find different hits (silhouettes and shadow edges, f32 rounding).

use super::native::{cone_normal, cone_t, Caster, Caster8, ConeF, Hit, Shade};
use super::{Peer, PeerError, PeerFrame};
use crate::accel::{PrimKind, PrimRef};
use crate::scene::Scene;
use glam::Vec3;
use std::ffi::c_void;
use sys::*;

/// Hand-written declarations of the part of the Embree 3 C API the peer uses, laid out as
/// /usr/include/embree3 (3.13, `RTC_MAX_INSTANCE_LEVEL_COUNT` 1, `RTC_MIN_WIDTH` 0);
/// tests/embree_peer.rs checks the sizes, alignments and offsets.
pub mod sys {
    use std::ffi::{c_char, c_void};

    pub type RTCDevice = *mut c_void;
    pub type RTCScene = *mut c_void;
    pub type RTCGeometry = *mut c_void;

    pub const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;
    pub const RTC_GEOMETRY_TYPE_TRIANGLE: u32 = 0;
    pub const RTC_GEOMETRY_TYPE_SPHERE_POINT: u32 = 50;
    pub const RTC_GEOMETRY_TYPE_USER: u32 = 120;
    pub const RTC_BUFFER_TYPE_INDEX: u32 = 0;
    pub const RTC_BUFFER_TYPE_VERTEX: u32 = 1;
    pub const RTC_FORMAT_UINT3: u32 = 0x5003;
    pub const RTC_FORMAT_FLOAT3: u32 = 0x9003;
    pub const RTC_FORMAT_FLOAT4: u32 = 0x9004;
    pub const RTC_BUILD_QUALITY_HIGH: u32 = 2;
    pub const RTC_SCENE_FLAG_NONE: u32 = 0;
    pub const RTC_SCENE_FLAG_ROBUST: u32 = 1 << 2;
    pub const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: u32 = 0;
    pub const RTC_DEVICE_PROPERTY_VERSION: u32 = 0;
    pub const RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED: u32 = 33;
    pub const RTC_ERROR_NONE: u32 = 0;

    #[repr(C, align(16))]
    #[derive(Clone, Copy, Debug, Default)]
    pub struct RTCRay {
        pub org_x: f32,
        pub org_y: f32,
        pub org_z: f32,
        pub tnear: f32,
        pub dir_x: f32,
        pub dir_y: f32,
        pub dir_z: f32,
        pub time: f32,
        pub tfar: f32,
        pub mask: u32,
        pub id: u32,
        pub flags: u32,
    }

    #[repr(C, align(16))]
    #[derive(Clone, Copy, Debug, Default)]
    pub struct RTCHit {
        pub ng_x: f32,
        pub ng_y: f32,
        pub ng_z: f32,
        pub u: f32,
        pub v: f32,
        pub prim_id: u32,
        pub geom_id: u32,
        pub inst_id: [u32; 1],
    }

    #[repr(C)]
    #[derive(Clone, Copy, Debug, Default)]
    pub struct RTCRayHit {
        pub ray: RTCRay,
        pub hit: RTCHit,
    }

    /// `RTCRay8`: each field of [`RTCRay`] for eight rays (structure of arrays).
    #[repr(C, align(32))]
    #[derive(Clone, Copy, Debug, Default)]
    pub struct RTCRay8 {
        pub org_x: [f32; 8],
        pub org_y: [f32; 8],
        pub org_z: [f32; 8],
        pub tnear: [f32; 8],
        pub dir_x: [f32; 8],
        pub dir_y: [f32; 8],
        pub dir_z: [f32; 8],
        pub time: [f32; 8],
        pub tfar: [f32; 8],
        pub mask: [u32; 8],
        pub id: [u32; 8],
        pub flags: [u32; 8],
    }

    #[repr(C, align(32))]
    #[derive(Clone, Copy, Debug, Default)]
    pub struct RTCHit8 {
        pub ng_x: [f32; 8],
        pub ng_y: [f32; 8],
        pub ng_z: [f32; 8],
        pub u: [f32; 8],
        pub v: [f32; 8],
        pub prim_id: [u32; 8],
        pub geom_id: [u32; 8],
        pub inst_id: [[u32; 8]; 1],
    }

    #[repr(C)]
    #[derive(Clone, Copy, Debug, Default)]
    pub struct RTCRayHit8 {
        pub ray: RTCRay8,
        pub hit: RTCHit8,
    }

    /// The valid mask of a packet call (-1: a ray, 0: none), aligned as the packet.
    #[repr(C, align(32))]
    #[derive(Clone, Copy, Debug, Default)]
    pub struct Valid8(pub [i32; 8]);

    pub type RTCFilterFunctionN = Option<unsafe extern "C" fn(args: *const c_void)>;

    #[repr(C)]
    #[derive(Clone, Copy, Debug)]
    pub struct RTCIntersectContext {
        pub flags: u32,
        pub filter: RTCFilterFunctionN,
        pub inst_id: [u32; 1],
    }

    impl RTCIntersectContext {
        /// As the header's inline `rtcInitIntersectContext` (not an exported symbol).
        pub fn new() -> Self {
            RTCIntersectContext {
                flags: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
                filter: None,
                inst_id: [RTC_INVALID_GEOMETRY_ID],
            }
        }
    }

    impl Default for RTCIntersectContext {
        fn default() -> Self {
            Self::new()
        }
    }

    #[repr(C, align(16))]
    #[derive(Clone, Copy, Debug, Default)]
    pub struct RTCBounds {
        pub lower_x: f32,
        pub lower_y: f32,
        pub lower_z: f32,
        pub align0: f32,
        pub upper_x: f32,
        pub upper_y: f32,
        pub upper_z: f32,
        pub align1: f32,
    }

    #[repr(C)]
    pub struct RTCBoundsFunctionArguments {
        pub geometry_user_ptr: *mut c_void,
        pub prim_id: u32,
        pub time_step: u32,
        pub bounds_o: *mut RTCBounds,
    }

    /// `rayhit` points at an `RTCRayHitN`: each field of `RTCRayHit` as an array of `n`.
    #[repr(C)]
    pub struct RTCIntersectFunctionNArguments {
        pub valid: *mut i32,
        pub geometry_user_ptr: *mut c_void,
        pub prim_id: u32,
        pub context: *mut RTCIntersectContext,
        pub rayhit: *mut c_void,
        pub n: u32,
        pub geom_id: u32,
    }

    /// `ray` points at an `RTCRayN`: each field of `RTCRay` as an array of `n`.
    #[repr(C)]
    pub struct RTCOccludedFunctionNArguments {
        pub valid: *mut i32,
        pub geometry_user_ptr: *mut c_void,
        pub prim_id: u32,
        pub context: *mut RTCIntersectContext,
        pub ray: *mut c_void,
        pub n: u32,
        pub geom_id: u32,
    }

    pub type RTCBoundsFunction = unsafe extern "C" fn(args: *const RTCBoundsFunctionArguments);
    pub type RTCIntersectFunctionN = unsafe extern "C" fn(args: *const RTCIntersectFunctionNArguments);
    pub type RTCOccludedFunctionN = unsafe extern "C" fn(args: *const RTCOccludedFunctionNArguments);

    #[link(name = "embree3")]
    extern "C" {
        pub fn rtcNewDevice(config: *const c_char) -> RTCDevice;
        pub fn rtcReleaseDevice(device: RTCDevice);
        pub fn rtcGetDeviceError(device: RTCDevice) -> u32;
        pub fn rtcGetDeviceProperty(device: RTCDevice, prop: u32) -> isize;
        pub fn rtcNewScene(device: RTCDevice) -> RTCScene;
        pub fn rtcReleaseScene(scene: RTCScene);
        pub fn rtcSetSceneFlags(scene: RTCScene, flags: u32);
        pub fn rtcSetSceneBuildQuality(scene: RTCScene, quality: u32);
        pub fn rtcAttachGeometry(scene: RTCScene, geometry: RTCGeometry) -> u32;
        pub fn rtcCommitScene(scene: RTCScene);
        pub fn rtcNewGeometry(device: RTCDevice, kind: u32) -> RTCGeometry;
        pub fn rtcReleaseGeometry(geometry: RTCGeometry);
        pub fn rtcCommitGeometry(geometry: RTCGeometry);
        pub fn rtcSetNewGeometryBuffer(
            geometry: RTCGeometry,
            kind: u32,
            slot: u32,
            format: u32,
            byte_stride: usize,
            item_count: usize,
        ) -> *mut c_void;
        pub fn rtcSetGeometryUserPrimitiveCount(geometry: RTCGeometry, count: u32);
        pub fn rtcSetGeometryUserData(geometry: RTCGeometry, ptr: *mut c_void);
        pub fn rtcSetGeometryBoundsFunction(geometry: RTCGeometry, f: RTCBoundsFunction, user: *mut c_void);
        pub fn rtcSetGeometryIntersectFunction(geometry: RTCGeometry, f: RTCIntersectFunctionN);
        pub fn rtcSetGeometryOccludedFunction(geometry: RTCGeometry, f: RTCOccludedFunctionN);
        pub fn rtcIntersect1(scene: RTCScene, context: *mut RTCIntersectContext, rayhit: *mut RTCRayHit);
        pub fn rtcOccluded1(scene: RTCScene, context: *mut RTCIntersectContext, ray: *mut RTCRay);
        pub fn rtcIntersect8(
            valid: *const i32,
            scene: RTCScene,
            context: *mut RTCIntersectContext,
            rayhit: *mut RTCRayHit8,
        );
        pub fn rtcOccluded8(
            valid: *const i32,
            scene: RTCScene,
            context: *mut RTCIntersectContext,
            ray: *mut RTCRay8,
        );
    }
}

fn error_name(e: u32) -> &'static str {
    match e {
        0 => "none",
        1 => "unknown error",
        2 => "invalid argument",
        3 => "invalid operation",
        4 => "out of memory",
        5 => "unsupported CPU",
        6 => "cancelled",
        _ => "unrecognised error code",
    }
}

/// The Embree library's version ("3.13.5"), from a device made for the purpose.
pub fn version() -> Result<String, PeerError> {
    // SAFETY: a null config is allowed; the device is released before returning.
    unsafe {
        let device = rtcNewDevice(std::ptr::null());
        if device.is_null() {
            return Err(PeerError::Embree {
                call: "rtcNewDevice".into(),
                error: error_name(rtcGetDeviceError(device)),
            });
        }
        let v = rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION);
        rtcReleaseDevice(device);
        Ok(format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100))
    }
}

/// An Embree device and committed scene of the workload's primitives; [`EmbreePeer::render`]
/// traces a frame.
pub struct EmbreePeer {
    robust: bool,
    packets: bool,
    shade: Shade,
    device: RTCDevice,
    scene: RTCScene,
    /// The primitive kind of each Embree geometry id.
    kinds: Vec<PrimKind>,
}

// SAFETY: a committed Embree scene may be traversed from any number of threads at once
// (rtcIntersect1 / rtcOccluded1 are thread-safe); nothing is modified after `new`.
unsafe impl Send for EmbreePeer {}
unsafe impl Sync for EmbreePeer {}

impl Drop for EmbreePeer {
    fn drop(&mut self) {
        // SAFETY: both were created by `new` and are released once.
        unsafe {
            rtcReleaseScene(self.scene);
            rtcReleaseDevice(self.device);
        }
    }
}

impl EmbreePeer {
    /// `scene` must be the primary-shadow workload (see [`super::primary_shadow`]). The scene is
    /// built with `RTC_SCENE_FLAG_ROBUST`: without it Embree's triangle test lets rays through
    /// edges shared by two triangles (measured: SPD rings_s2 at 160², four eye rays along a
    /// quad's diagonal see the background through the floor), while irt's test is watertight.
    pub fn new(scene: &Scene) -> Result<Self, PeerError> {
        Self::with_options(scene, true, false)
    }

    /// As [`EmbreePeer::new`], `robust = false` leaving Embree's default scene flags (its fastest
    /// traversal, not watertight; `irt bench --peer embree-fast`), `packets` tracing eight
    /// pixels of a row at a time with `rtcIntersect8` / `rtcOccluded8` (and each light's shadow
    /// rays of those pixels as one packet; `--peer embree-packet`) instead of single rays.
    pub fn with_options(scene: &Scene, robust: bool, packets: bool) -> Result<Self, PeerError> {
        let shade = Shade::new(scene, "embree")?;
        // SAFETY: every pointer Embree returns is checked before use; buffers are written within
        // the item counts they were created with; the cone user data points into
        // `shade.cones`, whose heap buffer lives (unmoved, unmodified) as long as the peer.
        unsafe {
            let device = rtcNewDevice(std::ptr::null());
            if device.is_null() {
                return Err(PeerError::Embree {
                    call: "rtcNewDevice".into(),
                    error: error_name(rtcGetDeviceError(device)),
                });
            }
            let rtc_scene = rtcNewScene(device);
            if rtc_scene.is_null() {
                let e = error_name(rtcGetDeviceError(device));
                rtcReleaseDevice(device);
                return Err(PeerError::Embree { call: "rtcNewScene".into(), error: e });
            }
            // From here on, Drop releases both on an error.
            let mut peer = EmbreePeer { robust, packets, shade, device, scene: rtc_scene, kinds: Vec::new() };
            if packets && rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) == 0 {
                return Err(PeerError::NoPackets);
            }
            rtcSetSceneFlags(rtc_scene, if robust { RTC_SCENE_FLAG_ROBUST } else { RTC_SCENE_FLAG_NONE });
            rtcSetSceneBuildQuality(rtc_scene, RTC_BUILD_QUALITY_HIGH);
            peer.add_triangles()?;
            peer.add_spheres()?;
            peer.add_cones()?;
            rtcCommitScene(rtc_scene);
            peer.check("rtcCommitScene")?;
            Ok(peer)
        }
    }

    fn check(&self, what: &'static str) -> Result<(), PeerError> {
        // SAFETY: a live device.
        match unsafe { rtcGetDeviceError(self.device) } {
            RTC_ERROR_NONE => Ok(()),
            e => Err(PeerError::EmbreeReports { what, error: error_name(e) }),
        }
    }

    /// Creates a geometry of `kind`, lets `fill` set it up, commits and attaches it.
    unsafe fn add(
        &mut self,
        kind: u32,
        prim: PrimKind,
        fill: impl FnOnce(RTCGeometry),
    ) -> Result<(), PeerError> {
        let g = rtcNewGeometry(self.device, kind);
        if g.is_null() {
            let error = error_name(rtcGetDeviceError(self.device));
            return Err(PeerError::Embree { call: format!("rtcNewGeometry({kind})"), error });
        }
        fill(g);
        rtcCommitGeometry(g);
        let id = rtcAttachGeometry(self.scene, g);
        rtcReleaseGeometry(g);
        self.check("building the Embree geometry")?;
        let id = id as usize;
        if self.kinds.len() <= id {
            self.kinds.resize(id + 1, prim);
        }
        self.kinds[id] = prim;
        Ok(())
    }

    /// A buffer Embree allocates (and pads as it needs), as a slice of `count` items.
    unsafe fn new_buffer<'a, T>(g: RTCGeometry, kind: u32, format: u32, count: usize) -> &'a mut [T] {
        let p = rtcSetNewGeometryBuffer(g, kind, 0, format, std::mem::size_of::<T>(), count) as *mut T;
        assert!(!p.is_null(), "rtcSetNewGeometryBuffer returned null");
        std::slice::from_raw_parts_mut(p, count)
    }

    unsafe fn add_triangles(&mut self) -> Result<(), PeerError> {
        let n = self.shade.triangles.len();
        if n == 0 {
            return Ok(());
        }
        let tris: Vec<[Vec3; 3]> = self.shade.triangles.iter().map(|t| t.p).collect();
        self.add(RTC_GEOMETRY_TYPE_TRIANGLE, PrimKind::Triangle, |g| {
            let v = Self::new_buffer::<[f32; 3]>(g, RTC_BUFFER_TYPE_VERTEX, RTC_FORMAT_FLOAT3, 3 * n);
            let idx = Self::new_buffer::<[u32; 3]>(g, RTC_BUFFER_TYPE_INDEX, RTC_FORMAT_UINT3, n);
            for (i, p) in tris.iter().enumerate() {
                for k in 0..3 {
                    v[3 * i + k] = p[k].to_array();
                }
                let b = 3 * i as u32;
                idx[i] = [b, b + 1, b + 2];
            }
        })
    }

    unsafe fn add_spheres(&mut self) -> Result<(), PeerError> {
        let n = self.shade.spheres.len();
        if n == 0 {
            return Ok(());
        }
        let balls: Vec<[f32; 4]> =
            self.shade.spheres.iter().map(|s| s.center.extend(s.radius).to_array()).collect();
        self.add(RTC_GEOMETRY_TYPE_SPHERE_POINT, PrimKind::Sphere, |g| {
            Self::new_buffer::<[f32; 4]>(g, RTC_BUFFER_TYPE_VERTEX, RTC_FORMAT_FLOAT4, n)
                .copy_from_slice(&balls);
        })
    }

    unsafe fn add_cones(&mut self) -> Result<(), PeerError> {
        let n = self.shade.cones.len();
        if n == 0 {
            return Ok(());
        }
        let user = self.shade.cones.as_ptr() as *mut c_void;
        self.add(RTC_GEOMETRY_TYPE_USER, PrimKind::Cone, |g| {
            rtcSetGeometryUserPrimitiveCount(g, n as u32);
            rtcSetGeometryUserData(g, user);
            rtcSetGeometryBoundsFunction(g, cone_bounds, std::ptr::null_mut());
            rtcSetGeometryIntersectFunction(g, cone_intersect);
            rtcSetGeometryOccludedFunction(g, cone_occluded);
        })
    }

    /// One frame on `threads` threads, as the native peer's.
    pub fn render(&self, threads: usize) -> PeerFrame {
        if self.packets {
            self.shade.render8(self, threads)
        } else {
            self.shade.render(self, threads)
        }
    }

    fn ray8(o: &[Vec3; 8], d: &[Vec3; 8], t_max: &[f32; 8]) -> RTCRay8 {
        RTCRay8 {
            org_x: o.map(|v| v.x),
            org_y: o.map(|v| v.y),
            org_z: o.map(|v| v.z),
            dir_x: d.map(|v| v.x),
            dir_y: d.map(|v| v.y),
            dir_z: d.map(|v| v.z),
            tfar: *t_max,
            mask: [u32::MAX; 8],
            ..Default::default()
        }
    }

    fn ray(o: Vec3, d: Vec3, t_max: f32) -> RTCRay {
        RTCRay {
            org_x: o.x,
            org_y: o.y,
            org_z: o.z,
            tnear: 0.0,
            dir_x: d.x,
            dir_y: d.y,
            dir_z: d.z,
            time: 0.0,
            tfar: t_max,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }
}

impl Caster for EmbreePeer {
    type Ctx = RTCIntersectContext;

    fn context(&self) -> RTCIntersectContext {
        RTCIntersectContext::new()
    }

    fn nearest(&self, ctx: &mut RTCIntersectContext, o: Vec3, d: Vec3, t_max: f32) -> Option<Hit> {
        let mut rh = RTCRayHit {
            ray: Self::ray(o, d, t_max),
            hit: RTCHit {
                geom_id: RTC_INVALID_GEOMETRY_ID,
                prim_id: RTC_INVALID_GEOMETRY_ID,
                inst_id: [RTC_INVALID_GEOMETRY_ID],
                ..Default::default()
            },
        };
        // SAFETY: a committed scene, an initialised context, an aligned ray/hit.
        unsafe { rtcIntersect1(self.scene, ctx, &mut rh) };
        let h = rh.hit;
        (h.geom_id != RTC_INVALID_GEOMETRY_ID).then(|| Hit {
            t: rh.ray.tfar,
            prim: PrimRef::new(self.kinds[h.geom_id as usize], h.prim_id),
            b: (h.u, h.v),
        })
    }

    fn occluded(&self, ctx: &mut RTCIntersectContext, o: Vec3, d: Vec3, t_max: f32) -> bool {
        let mut ray = Self::ray(o, d, t_max);
        // SAFETY: as in `nearest`. Embree sets tfar to -inf when something is hit.
        unsafe { rtcOccluded1(self.scene, ctx, &mut ray) };
        ray.tfar == f32::NEG_INFINITY
    }
}

impl Caster8 for EmbreePeer {
    type Ctx = RTCIntersectContext;

    fn context(&self) -> RTCIntersectContext {
        RTCIntersectContext::new()
    }

    fn nearest8(
        &self,
        ctx: &mut RTCIntersectContext,
        o: &[Vec3; 8],
        d: &[Vec3; 8],
        t_max: &[f32; 8],
        active: &[bool; 8],
    ) -> [Option<Hit>; 8] {
        let valid = Valid8(active.map(|a| if a { -1 } else { 0 }));
        let mut rh = RTCRayHit8 { ray: Self::ray8(o, d, t_max), hit: RTCHit8::default() };
        rh.hit.geom_id = [RTC_INVALID_GEOMETRY_ID; 8];
        rh.hit.inst_id = [[RTC_INVALID_GEOMETRY_ID; 8]];
        // SAFETY: a committed scene, an initialised context, 32-byte aligned mask and packet.
        unsafe { rtcIntersect8(valid.0.as_ptr(), self.scene, ctx, &mut rh) };
        let h = &rh.hit;
        std::array::from_fn(|i| {
            (active[i] && h.geom_id[i] != RTC_INVALID_GEOMETRY_ID).then(|| Hit {
                t: rh.ray.tfar[i],
                prim: PrimRef::new(self.kinds[h.geom_id[i] as usize], h.prim_id[i]),
                b: (h.u[i], h.v[i]),
            })
        })
    }

    fn occluded8(
        &self,
        ctx: &mut RTCIntersectContext,
        o: &[Vec3; 8],
        d: &[Vec3; 8],
        t_max: &[f32; 8],
        active: &[bool; 8],
    ) -> [bool; 8] {
        let valid = Valid8(active.map(|a| if a { -1 } else { 0 }));
        let mut ray = Self::ray8(o, d, t_max);
        // SAFETY: as in `nearest8`.
        unsafe { rtcOccluded8(valid.0.as_ptr(), self.scene, ctx, &mut ray) };
        std::array::from_fn(|i| active[i] && ray.tfar[i] == f32::NEG_INFINITY)
    }
}

impl Peer for EmbreePeer {
    fn name(&self) -> &'static str {
        match (self.robust, self.packets) {
            (true, false) => "embree",
            (false, false) => "embree-fast",
            (true, true) => "embree-packet",
            (false, true) => "embree-fast-packet",
        }
    }
    fn render(&self, threads: usize) -> PeerFrame {
        EmbreePeer::render(self, threads)
    }
}

/// Axis-aligned box of the open cone: both end discs (radius r, unit axis a: extent
/// r·√(1 − a_i²) along axis i), padded for f32 rounding.
fn cone_box(c: &ConeF) -> (Vec3, Vec3) {
    let a = c.axis.normalize_or_zero();
    let e: Vec3 = (Vec3::ONE - a * a).max(Vec3::ZERO).to_array().map(f32::sqrt).into();
    let apex = c.base + c.axis;
    let lo = (c.base - e * c.r0).min(apex - e * c.r1);
    let hi = (c.base + e * c.r0).max(apex + e * c.r1);
    let pad = 1e-5 * (lo.abs().max(hi.abs()).max_element() + c.r0.max(c.r1));
    (lo - pad, hi + pad)
}

unsafe fn cone_of<'a>(user: *mut c_void, prim: u32) -> &'a ConeF {
    &*(user as *const ConeF).add(prim as usize)
}

unsafe extern "C" fn cone_bounds(args: *const RTCBoundsFunctionArguments) {
    let a = &*args;
    let (lo, hi) = cone_box(cone_of(a.geometry_user_ptr, a.prim_id));
    *a.bounds_o = RTCBounds {
        lower_x: lo.x,
        lower_y: lo.y,
        lower_z: lo.z,
        align0: 0.0,
        upper_x: hi.x,
        upper_y: hi.y,
        upper_z: hi.z,
        align1: 0.0,
    };
}

/// Field `k` (in `RTCRay` then `RTCHit` order, 4 bytes each) of ray `i` in an N-wide SOA block.
unsafe fn field(base: *mut c_void, n: usize, k: usize, i: usize) -> *mut f32 {
    (base as *mut f32).add(k * n + i)
}

unsafe fn ray_of(base: *mut c_void, n: usize, i: usize) -> (Vec3, Vec3, f32, f32) {
    let g = |k| *field(base, n, k, i);
    (Vec3::new(g(0), g(1), g(2)), Vec3::new(g(4), g(5), g(6)), g(3), g(8))
}

unsafe extern "C" fn cone_intersect(args: *const RTCIntersectFunctionNArguments) {
    let a = &*args;
    let c = cone_of(a.geometry_user_ptr, a.prim_id);
    let (base, n) = (a.rayhit, a.n as usize);
    for i in 0..n {
        if *a.valid.add(i) == 0 {
            continue;
        }
        let (o, d, tnear, tfar) = ray_of(base, n, i);
        if let Some(t) = cone_t(o, d, c, tnear, tfar) {
            let ng = cone_normal(o + d * t, c);
            *field(base, n, 8, i) = t;
            for (k, x) in [(12, ng.x), (13, ng.y), (14, ng.z), (15, 0.0), (16, 0.0)] {
                *field(base, n, k, i) = x;
            }
            let u = |k| field(base, n, k, i) as *mut u32;
            *u(17) = a.prim_id;
            *u(18) = a.geom_id;
            *u(19) = (*a.context).inst_id[0];
        }
    }
}

unsafe extern "C" fn cone_occluded(args: *const RTCOccludedFunctionNArguments) {
    let a = &*args;
    let c = cone_of(a.geometry_user_ptr, a.prim_id);
    let (base, n) = (a.ray, a.n as usize);
    for i in 0..n {
        if *a.valid.add(i) == 0 {
            continue;
        }
        let (o, d, tnear, tfar) = ray_of(base, n, i);
        if cone_t(o, d, c, tnear, tfar).is_some() {
            *field(base, n, 8, i) = f32::NEG_INFINITY;
        }
    }
}
