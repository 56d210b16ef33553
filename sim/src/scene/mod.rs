//! The simulated world's geometry: analytic primitives in BVHs, materials with procedural
//! textures, and movable object groups (wire, grounding rod) over static hierarchies.
//!
//! # Conventions
//! * World frame = `map`: x east, y north, z up, metres; f64 throughout.
//! * A movable object keeps its primitives in its own frame with a static BVH; moving it only
//!   changes `world_from_object` (an `Isometry3<f64>`), so wire sway and rod motion between
//!   captures cost O(1). Rays are mapped into the object frame (`object_from_world`), which
//!   preserves distances, so hit distances from all hierarchies compare directly.
//! * The ground is an analytic plane, level or graded ([`ground`]; not in a BVH).

pub mod bvh;
pub mod catenary;
pub mod ground;
pub mod grounding_rod;
pub mod noise;
pub mod primitives;
pub mod steel;
pub mod substation;
pub mod textures;

use nalgebra::{Isometry3, Point3, Vector3};

use bvh::Bvh;
pub use bvh::{Candidates, Slab};
pub use catenary::Catenary;
pub use ground::{Ground, GroundPlane};
pub use primitives::{Aabb, Primitive, Ray, Shape};
pub use substation::{SubstationBuilder, SubstationLayout, SubstationParams};
pub use textures::{Material, Shading, Texture};

/// Index of a material in a [`Scene`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct MaterialId(pub u16);

/// Index of a movable object in a [`Scene`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ObjectId(pub u32);

/// Errors of scene construction and object access.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SceneError {
    /// A primitive refers to a material that was not added.
    #[error("primitive {primitive} uses material {material} but the scene has {count} materials")]
    UnknownMaterial {
        /// Primitive index in insertion order.
        primitive: usize,
        /// The material index it used.
        material: u16,
        /// Number of materials in the scene.
        count: usize,
    },
    /// A shape has a non-finite or non-positive size.
    #[error("primitive {primitive} is degenerate: {what} = {value}")]
    DegenerateShape {
        /// Primitive index in insertion order.
        primitive: usize,
        /// Which quantity.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// Too many materials for the 16-bit index.
    #[error("too many materials: {count} (max 65535)")]
    TooManyMaterials {
        /// How many were added.
        count: usize,
    },
    /// Object index out of range.
    #[error("object {index} does not exist (scene has {count})")]
    UnknownObject {
        /// Requested index.
        index: u32,
        /// Number of objects.
        count: usize,
    },
}

/// A movable group of primitives with its own BVH.
#[derive(Clone, Debug)]
pub struct SceneObject {
    name: String,
    bvh: Bvh,
    local_bounds: Aabb,
    world_from_object: Isometry3<f64>,
    object_from_world: Isometry3<f64>,
    world_bounds: Aabb,
}

impl SceneObject {
    /// Name given at construction.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Current pose.
    #[must_use]
    pub fn world_from_object(&self) -> &Isometry3<f64> {
        &self.world_from_object
    }

    /// Its primitives, in the object's frame.
    #[must_use]
    pub fn primitives(&self) -> &[Primitive] {
        self.bvh.primitives()
    }

    fn set_pose(&mut self, world_from_object: Isometry3<f64>) {
        self.world_from_object = world_from_object;
        self.object_from_world = world_from_object.inverse();
        self.world_bounds = self.local_bounds.transformed(|p| world_from_object * p);
    }
}

/// Which hierarchy a hit came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HitSource {
    /// The ground plane.
    Ground,
    /// The static BVH.
    Static,
    /// A movable object.
    Object(ObjectId),
}

/// Closest intersection of a ray with the scene.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the (unit) ray, metres.
    pub t_m: f64,
    /// Where it came from.
    pub source: HitSource,
    /// Primitive index within its hierarchy (0 for the ground).
    pub prim: u32,
}

impl Hit {
    /// A key that differs between distinct primitives (used for edge detection).
    #[must_use]
    pub fn key(&self) -> u64 {
        let s = match self.source {
            HitSource::Ground => 0u64,
            HitSource::Static => 1,
            HitSource::Object(o) => 2 + u64::from(o.0),
        };
        (s << 32) | u64::from(self.prim)
    }
}

/// Surface attributes at a hit, in the world frame (and texture coordinates in the
/// primitive's own frame so textures move with their object).
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    /// Hit point (world).
    pub point: Point3<f64>,
    /// Outward unit normal (world).
    pub normal: Vector3<f64>,
    /// Surface coordinates in metres.
    pub uv_m: [f64; 2],
    /// Face index of the primitive.
    pub face: u8,
    /// Material.
    pub material: MaterialId,
}

/// A renderable world: static BVH, ground plane, movable objects and materials.
#[derive(Clone, Debug)]
pub struct Scene {
    materials: Vec<Material>,
    statics: Bvh,
    ground: Option<Ground>,
    objects: Vec<SceneObject>,
}

/// Accumulates primitives, objects and materials, then builds a [`Scene`].
#[derive(Clone, Debug, Default)]
pub struct SceneBuilder {
    materials: Vec<Material>,
    statics: Vec<Primitive>,
    ground: Option<Ground>,
    objects: Vec<(String, Vec<Primitive>, Isometry3<f64>)>,
}

impl SceneBuilder {
    /// Empty builder.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a material and returns its id (ids beyond 65535 are reported by [`Self::build`]).
    pub fn material(&mut self, m: Material) -> MaterialId {
        let id = MaterialId(u16::try_from(self.materials.len()).unwrap_or(u16::MAX));
        self.materials.push(m);
        id
    }

    /// Sets the ground.
    pub fn ground(&mut self, plane: GroundPlane, material: MaterialId) {
        self.ground = Some(Ground { plane, material });
    }

    /// Adds a static primitive.
    pub fn add(&mut self, shape: Shape, material: MaterialId) {
        self.statics.push(Primitive { shape, material });
    }

    /// Adds the static primitives `build` adds, raised by `dz_m`: a structure designed
    /// standing at `z = 0`, placed on ground of height `dz_m`.
    pub fn raised<T>(&mut self, dz_m: f64, build: impl FnOnce(&mut Self) -> T) -> T {
        let first = self.statics.len();
        let built = build(self);
        if dz_m != 0.0 {
            let up = Vector3::new(0.0, 0.0, dz_m);
            for p in &mut self.statics[first..] {
                p.shape.translate(&up);
            }
        }
        built
    }

    /// Adds a movable object whose primitives are given in its own frame; returns its id.
    pub fn object(
        &mut self,
        name: &str,
        prims: Vec<Primitive>,
        world_from_object: Isometry3<f64>,
    ) -> ObjectId {
        self.objects
            .push((name.to_owned(), prims, world_from_object));
        ObjectId((self.objects.len() - 1) as u32)
    }

    /// Number of static primitives so far.
    #[must_use]
    pub fn static_count(&self) -> usize {
        self.statics.len()
    }

    /// Validates and builds the BVHs.
    ///
    /// # Errors
    /// [`SceneError::UnknownMaterial`], [`SceneError::DegenerateShape`],
    /// [`SceneError::TooManyMaterials`].
    pub fn build(self) -> Result<Scene, SceneError> {
        if self.materials.len() > usize::from(u16::MAX) {
            return Err(SceneError::TooManyMaterials {
                count: self.materials.len(),
            });
        }
        let count = self.materials.len();
        let all = self
            .statics
            .iter()
            .chain(self.objects.iter().flat_map(|o| o.1.iter()));
        for (i, p) in all.enumerate() {
            validate(i, p, count)?;
        }
        if let Some(g) = &self.ground
            && usize::from(g.material.0) >= count
        {
            return Err(SceneError::UnknownMaterial {
                primitive: usize::MAX,
                material: g.material.0,
                count,
            });
        }
        let objects = self
            .objects
            .into_iter()
            .map(|(name, prims, pose)| {
                let bvh = Bvh::build(prims);
                let local_bounds = bvh.bounds();
                let mut o = SceneObject {
                    name,
                    bvh,
                    local_bounds,
                    world_from_object: pose,
                    object_from_world: pose.inverse(),
                    world_bounds: Aabb::EMPTY,
                };
                o.set_pose(pose);
                o
            })
            .collect();
        Ok(Scene {
            materials: self.materials,
            statics: Bvh::build(self.statics),
            ground: self.ground,
            objects,
        })
    }
}

fn validate(i: usize, p: &Primitive, count: usize) -> Result<(), SceneError> {
    if usize::from(p.material.0) >= count {
        return Err(SceneError::UnknownMaterial {
            primitive: i,
            material: p.material.0,
            count,
        });
    }
    let check = |what: &'static str, value: f64| {
        if value.is_finite() && value > 0.0 {
            Ok(())
        } else {
            Err(SceneError::DegenerateShape {
                primitive: i,
                what,
                value,
            })
        }
    };
    match &p.shape {
        Shape::Sphere { radius_m, .. } => check("radius_m", *radius_m),
        Shape::Cylinder {
            axis,
            length_m,
            radius_m,
            ..
        } => {
            check("radius_m", *radius_m)?;
            check("length_m", *length_m)?;
            let n = axis.norm();
            if (n - 1.0).abs() > 1e-9 {
                return Err(SceneError::DegenerateShape {
                    primitive: i,
                    what: "|axis|",
                    value: n,
                });
            }
            Ok(())
        }
        Shape::Box { half_extents_m, .. } => {
            for k in 0..3 {
                check("half_extent_m", half_extents_m[k])?;
            }
            Ok(())
        }
    }
}

impl Scene {
    /// Materials (indexed by [`MaterialId`]).
    #[must_use]
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// Material by id (the default material if out of range, which `build` rules out).
    #[must_use]
    pub fn material(&self, id: MaterialId) -> &Material {
        self.materials
            .get(usize::from(id.0))
            .unwrap_or(&textures::FALLBACK_MATERIAL)
    }

    /// Movable objects.
    #[must_use]
    pub fn objects(&self) -> &[SceneObject] {
        &self.objects
    }

    /// Id of the first object with this name.
    #[must_use]
    pub fn object_id(&self, name: &str) -> Option<ObjectId> {
        self.objects
            .iter()
            .position(|o| o.name == name)
            .map(|i| ObjectId(i as u32))
    }

    /// Number of static primitives.
    #[must_use]
    pub fn static_primitive_count(&self) -> usize {
        self.statics.primitives().len()
    }

    /// The static primitives (world frame), e.g. for a judge's collision geometry.
    #[must_use]
    pub fn static_primitives(&self) -> &[Primitive] {
        self.statics.primitives()
    }

    /// Moves an object (O(1): one isometry and 8 transformed corners).
    ///
    /// # Errors
    /// [`SceneError::UnknownObject`] if `id` is out of range.
    pub fn set_object_pose(
        &mut self,
        id: ObjectId,
        world_from_object: Isometry3<f64>,
    ) -> Result<(), SceneError> {
        let count = self.objects.len();
        let o = self
            .objects
            .get_mut(id.0 as usize)
            .ok_or(SceneError::UnknownObject { index: id.0, count })?;
        o.set_pose(world_from_object);
        Ok(())
    }

    /// Closest hit of a unit-direction ray with `t` in `(t_min, t_max)`.
    #[inline]
    #[must_use]
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        self.intersect_hinted(ray, t_min, t_max, None)
    }

    /// The ground plane's hit of `ray` in `(t_min, t_max)`, if there is a ground.
    #[inline]
    fn ground_hit(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        let t = self.ground?.hit(ray, t_min, t_max)?;
        Some(Hit {
            t_m: t,
            source: HitSource::Ground,
            prim: 0,
        })
    }

    /// Distance to one given primitive (`None` if missed or unknown).
    #[inline]
    #[must_use]
    pub fn intersect_primitive(
        &self,
        ray: &Ray,
        source: HitSource,
        prim: u32,
        t_min: f64,
        t_max: f64,
    ) -> Option<Hit> {
        let t = match source {
            HitSource::Ground => self.ground?.hit(ray, t_min, t_max)?,
            HitSource::Static => self
                .statics
                .primitives()
                .get(prim as usize)?
                .shape
                .intersect(ray, t_min, t_max)?,
            HitSource::Object(id) => {
                let obj = self.objects.get(id.0 as usize)?;
                let local = Ray {
                    origin: obj.object_from_world * ray.origin,
                    dir: obj.object_from_world.rotation * ray.dir,
                };
                obj.bvh
                    .primitives()
                    .get(prim as usize)?
                    .shape
                    .intersect(&local, t_min, t_max)?
            }
        };
        Some(Hit {
            t_m: t,
            source,
            prim,
        })
    }

    /// [`Self::intersect`] that first tests the primitive of `hint` (e.g. the previous
    /// pixel's hit): a close first bound prunes most of the hierarchy. The result is the same
    /// closest hit (on an exact tie in `t` the hinted primitive wins).
    #[inline]
    #[must_use]
    pub fn intersect_hinted(
        &self,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        hint: Option<Hit>,
    ) -> Option<Hit> {
        let mut best =
            hint.and_then(|h| self.intersect_primitive(ray, h.source, h.prim, t_min, t_max));
        let mut t_best = best.map_or(t_max, |h| h.t_m);
        if let Some(h) = self.ground_hit(ray, t_min, t_best) {
            t_best = h.t_m;
            best = Some(h);
        }
        if let Some(h) = self.statics.intersect(ray, t_min, t_best) {
            t_best = h.t_m;
            best = Some(Hit {
                t_m: h.t_m,
                source: HitSource::Static,
                prim: h.prim,
            });
        }
        let o = [ray.origin.x, ray.origin.y, ray.origin.z];
        let inv = [1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z];
        for (i, obj) in self.objects.iter().enumerate() {
            if obj.world_bounds.hit(&o, &inv, t_best).is_none() {
                continue;
            }
            let local = Ray {
                origin: obj.object_from_world * ray.origin,
                dir: obj.object_from_world.rotation * ray.dir,
            };
            if let Some(h) = obj.bvh.intersect(&local, t_min, t_best) {
                t_best = h.t_m;
                best = Some(Hit {
                    t_m: h.t_m,
                    source: HitSource::Object(ObjectId(i as u32)),
                    prim: h.prim,
                });
            }
        }
        best
    }

    /// Culls the static hierarchy and the movable objects with a convex volume (`slabs`)
    /// that contains a bundle of rays (a pixel tile's frustum, a beam of shadow rays) whose
    /// origins lie in the box `origins_lo ..= origins_hi`; see [`Bvh::cull`]. `limit` caps
    /// the number of static candidates.
    pub fn cull(
        &self,
        slabs: &[Slab],
        origins_lo: [f64; 3],
        origins_hi: [f64; 3],
        limit: usize,
        out: &mut Candidates,
    ) {
        self.statics.cull(slabs, origins_lo, origins_hi, limit, out);
        out.objects.clear();
        for (i, obj) in self.objects.iter().enumerate() {
            // A 1 mm pad covers the rounding of the transformed corners.
            let lo = obj.world_bounds.min.map(|x| x - 1e-3);
            let hi = obj.world_bounds.max.map(|x| x + 1e-3);
            if bvh::box_overlaps_slabs(lo, hi, slabs) {
                out.objects.push(i as u32);
            }
        }
    }

    /// [`Self::intersect`] for a ray inside the volume `statics` was culled with: the same
    /// closest hit, testing only the candidate static primitives.
    #[inline]
    #[must_use]
    pub fn intersect_culled(
        &self,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        statics: &Candidates,
    ) -> Option<Hit> {
        self.intersect_culled_hinted(ray, t_min, t_max, statics, &mut None)
    }

    /// [`Self::intersect_culled`] testing the static candidate `*hint` first (see
    /// [`Bvh::intersect_candidates_hinted`]; same result).
    #[inline]
    #[must_use]
    pub fn intersect_culled_hinted(
        &self,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        statics: &Candidates,
        hint: &mut Option<usize>,
    ) -> Option<Hit> {
        let mut best = None;
        let mut t_best = t_max;
        if let Some(h) = self.ground_hit(ray, t_min, t_best) {
            t_best = h.t_m;
            best = Some(h);
        }
        if let Some(h) = self
            .statics
            .intersect_candidates_hinted(statics, ray, t_min, t_best, hint)
        {
            t_best = h.t_m;
            best = Some(Hit {
                t_m: h.t_m,
                source: HitSource::Static,
                prim: h.prim,
            });
        }
        self.intersect_objects(ray, t_min, t_best, best, &statics.objects)
    }

    /// [`Self::occluded`] for a ray inside the volume `statics` was culled with (same answer).
    #[inline]
    #[must_use]
    pub fn occluded_culled(&self, ray: &Ray, t_min: f64, t_max: f64, statics: &Candidates) -> bool {
        if self.ground_hit(ray, t_min, t_max).is_some() {
            return true;
        }
        if self
            .statics
            .occluder_candidates(statics, ray, t_min, t_max)
            .is_some()
        {
            return true;
        }
        self.objects_occlude(ray, t_min, t_max, &statics.objects)
    }

    /// Closest hit below `t_best` among the objects `which`, else `best`.
    #[inline]
    fn intersect_objects(
        &self,
        ray: &Ray,
        t_min: f64,
        mut t_best: f64,
        mut best: Option<Hit>,
        which: &[u32],
    ) -> Option<Hit> {
        if which.is_empty() {
            return best;
        }
        let o = [ray.origin.x, ray.origin.y, ray.origin.z];
        let inv = [1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z];
        for &i in which {
            let Some(obj) = self.objects.get(i as usize) else {
                continue;
            };
            if obj.world_bounds.hit(&o, &inv, t_best).is_none() {
                continue;
            }
            let local = Ray {
                origin: obj.object_from_world * ray.origin,
                dir: obj.object_from_world.rotation * ray.dir,
            };
            if let Some(h) = obj.bvh.intersect(&local, t_min, t_best) {
                t_best = h.t_m;
                best = Some(Hit {
                    t_m: h.t_m,
                    source: HitSource::Object(ObjectId(i)),
                    prim: h.prim,
                });
            }
        }
        best
    }

    /// Whether one of the objects `which` blocks the ray within `(t_min, t_max)`.
    #[inline]
    fn objects_occlude(&self, ray: &Ray, t_min: f64, t_max: f64, which: &[u32]) -> bool {
        if which.is_empty() {
            return false;
        }
        let o = [ray.origin.x, ray.origin.y, ray.origin.z];
        let inv = [1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z];
        which
            .iter()
            .filter_map(|&i| self.objects.get(i as usize))
            .any(|obj| {
                obj.world_bounds.hit(&o, &inv, t_max).is_some() && {
                    let local = Ray {
                        origin: obj.object_from_world * ray.origin,
                        dir: obj.object_from_world.rotation * ray.dir,
                    };
                    obj.bvh.occluder(&local, t_min, t_max).is_some()
                }
            })
    }

    /// Whether anything blocks the ray within `(t_min, t_max)` (shadow rays).
    #[inline]
    #[must_use]
    pub fn occluded(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.occluded_hinted(ray, t_min, t_max, &mut None)
    }

    /// [`Self::occluded`] that first tests the last occluder in `hint` and stores the new one
    /// there (neighbouring shadow rays are usually blocked by the same primitive). The
    /// answer does not depend on the hint.
    #[inline]
    pub fn occluded_hinted(
        &self,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        hint: &mut Option<Hit>,
    ) -> bool {
        if let Some(h) = *hint
            && self
                .intersect_primitive(ray, h.source, h.prim, t_min, t_max)
                .is_some()
        {
            return true;
        }
        if let Some(h) = self.ground_hit(ray, t_min, t_max) {
            *hint = Some(h);
            return true;
        }
        if let Some(prim) = self.statics.occluder(ray, t_min, t_max) {
            *hint = Some(Hit {
                t_m: 0.0,
                source: HitSource::Static,
                prim,
            });
            return true;
        }
        let o = [ray.origin.x, ray.origin.y, ray.origin.z];
        let inv = [1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z];
        for (i, obj) in self.objects.iter().enumerate() {
            if obj.world_bounds.hit(&o, &inv, t_max).is_none() {
                continue;
            }
            let local = Ray {
                origin: obj.object_from_world * ray.origin,
                dir: obj.object_from_world.rotation * ray.dir,
            };
            if let Some(prim) = obj.bvh.occluder(&local, t_min, t_max) {
                *hint = Some(Hit {
                    t_m: 0.0,
                    source: HitSource::Object(ObjectId(i as u32)),
                    prim,
                });
                return true;
            }
        }
        false
    }

    /// Surface attributes of a hit produced by [`Self::intersect`] for the same ray.
    #[must_use]
    #[inline]
    pub fn surface(&self, ray: &Ray, hit: &Hit) -> Option<SurfacePoint> {
        let p = ray.at(hit.t_m);
        match hit.source {
            HitSource::Ground => {
                let g = self.ground?;
                Some(SurfacePoint {
                    point: p,
                    normal: g.plane.normal(),
                    uv_m: [p.x, p.y],
                    face: 0,
                    material: g.material,
                })
            }
            HitSource::Static => {
                let prim = self.statics.primitives().get(hit.prim as usize)?;
                let s = prim.shape.surface(p);
                Some(SurfacePoint {
                    point: p,
                    normal: s.normal,
                    uv_m: s.uv_m,
                    face: s.face,
                    material: prim.material,
                })
            }
            HitSource::Object(id) => {
                let obj = self.objects.get(id.0 as usize)?;
                let prim = obj.bvh.primitives().get(hit.prim as usize)?;
                let s = prim.shape.surface(obj.object_from_world * p);
                Some(SurfacePoint {
                    point: p,
                    normal: obj.world_from_object.rotation * s.normal,
                    uv_m: s.uv_m,
                    face: s.face,
                    material: prim.material,
                })
            }
        }
    }
}
