//! A typed, fluent builder for scenes: a thin layer over [`SceneDesc`] and [`Scene::new`].
//!
//! The builder only fills in a [`SceneDesc`]; every check happens once, in
//! [`SceneBuilder::build`], which calls [`Scene::new`]. So a scene built in Rust is
//! validated exactly like one loaded from JSON, and its errors name the same field paths
//! (`height_fog[1].components[0].scattering[2]`, `lighting.sun.direction`, ...). The
//! [`Scene`] it returns cannot be changed afterwards, so a valid scene stays valid.

use crate::error::SceneError;
use crate::light::{Lobe, Phase};
use crate::medium::distance::DistanceFog;
use crate::medium::volume::Volume;
use crate::scene::{
    Component, Composition, FogLimits, HeightFogLayer, Lighting, Scene, SceneDesc, Sun, Tier,
};
use glam::Vec3;

/// Builds a [`Scene`] step by step; [`SceneBuilder::build`] validates it with
/// [`Scene::new`].
///
/// Every method takes the builder by value and returns it, so calls chain. Nothing is
/// checked before `build`: the builder holds a plain [`SceneDesc`] (see
/// [`SceneBuilder::desc`]), and `build` reports the first invalid value as a
/// [`SceneError`] naming its field, exactly as for the same scene written as JSON.
/// Methods that add something (`height_fog`, `layer`, `volume`) append, in call order;
/// methods that set something (`up`, `ambient`, `sun`, `tier`, ...) replace the previous
/// value. Unset fields keep [`SceneDesc::default`]'s values.
///
/// ```
/// use analytic_fog::{Component, Phase, SceneBuilder, SceneError};
/// use glam::Vec3;
///
/// let scene = SceneBuilder::new()
///     .layer(0.0, 0.08, Component::new(Vec3::splat(0.02), Phase::HenyeyGreenstein(0.7)))
///     .ambient(Vec3::new(0.5, 0.6, 0.7))
///     .sun(Vec3::new(0.3, 0.4, -0.87), Vec3::new(20.0, 18.0, 15.0))
///     .build()?;
///
/// let s = scene.eval_ray(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, -0.1, 1.0), 100.0);
/// assert!(s.transmittance.x > 0.0 && s.transmittance.x < 1.0);
/// assert!(s.inscattering.x > 0.0);
///
/// // Invalid values are reported by `build`, with the field's path.
/// let err = SceneBuilder::new()
///     .layer(0.0, 0.08, Component::isotropic(Vec3::splat(0.02)))
///     .layer(5.0, 0.2, Component::isotropic(Vec3::new(0.01, -0.2, 0.01)))
///     .build()
///     .unwrap_err();
/// assert_eq!(err.field(), "height_fog[1].components[0].scattering[1]");
/// assert!(matches!(err, SceneError::Negative { .. }));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
#[must_use = "a builder does nothing until `build` is called"]
pub struct SceneBuilder {
    desc: SceneDesc,
}

impl SceneBuilder {
    /// An empty scene: up +Y, no fog, no light, the Accurate tier (as
    /// [`SceneDesc::default`]).
    pub fn new() -> SceneBuilder {
        SceneBuilder::default()
    }

    /// A builder that starts from an existing description (e.g. one loaded from JSON).
    pub fn from_desc(desc: SceneDesc) -> SceneBuilder {
        SceneBuilder { desc }
    }

    /// Sets the up vector ([`SceneDesc::up`]; normalized by the library, must not be
    /// zero).
    pub fn up(mut self, up: Vec3) -> SceneBuilder {
        self.desc.up = up;
        self
    }

    /// Appends a height fog layer ([`SceneDesc::height_fog`]).
    pub fn height_fog(mut self, layer: HeightFogLayer) -> SceneBuilder {
        self.desc.height_fog.push(layer);
        self
    }

    /// Appends a height fog layer with one component and no emission: the common case of
    /// [`SceneBuilder::height_fog`].
    pub fn layer(self, base_height: f32, falloff: f32, component: Component) -> SceneBuilder {
        self.height_fog(HeightFogLayer {
            base_height,
            falloff,
            components: vec![component],
            emission: Vec3::ZERO,
        })
    }

    /// Sets all the lighting at once ([`SceneDesc::lighting`]), replacing the ambient
    /// light and the sun.
    pub fn lighting(mut self, lighting: Lighting) -> SceneBuilder {
        self.desc.lighting = lighting;
        self
    }

    /// Sets the ambient light ([`Lighting::ambient`], RGB, ≥ 0).
    pub fn ambient(mut self, ambient: Vec3) -> SceneBuilder {
        self.desc.lighting.ambient = ambient;
        self
    }

    /// Sets the sun ([`Lighting::sun`]): `direction` toward the sun (any non-zero
    /// length), `radiance` its RGB radiance (≥ 0).
    pub fn sun(mut self, direction: Vec3, radiance: Vec3) -> SceneBuilder {
        self.desc.lighting.sun = Some(Sun {
            direction,
            radiance,
        });
        self
    }

    /// Appends a fog volume or cut-out ([`SceneDesc::volumes`]).
    pub fn volume(mut self, volume: Volume) -> SceneBuilder {
        self.desc.volumes.push(volume);
        self
    }

    /// Sets the distance fog ([`SceneDesc::distance_fog`]).
    pub fn distance_fog(mut self, fog: DistanceFog) -> SceneBuilder {
        self.desc.distance_fog = Some(fog);
        self
    }

    /// Sets the start distance, cutoff distance and maximum opacity at once
    /// ([`SceneDesc::limits`]).
    pub fn limits(mut self, limits: FogLimits) -> SceneBuilder {
        self.desc.limits = limits;
        self
    }

    /// Sets [`FogLimits::start_distance`] (≥ 0): no fog closer to the camera.
    pub fn start_distance(mut self, distance: f32) -> SceneBuilder {
        self.desc.limits.start_distance = distance;
        self
    }

    /// Sets [`FogLimits::cutoff_distance`] (≥ 0): no fog farther from the camera.
    pub fn cutoff_distance(mut self, distance: f32) -> SceneBuilder {
        self.desc.limits.cutoff_distance = Some(distance);
        self
    }

    /// Sets [`FogLimits::max_opacity`] (in [0, 1]): the largest opacity 1 − T.
    pub fn max_opacity(mut self, opacity: f32) -> SceneBuilder {
        self.desc.limits.max_opacity = opacity;
        self
    }

    /// Sets the directional in-scattering lobe ([`SceneDesc::lobe`]; needs a sun).
    pub fn lobe(mut self, lobe: Lobe) -> SceneBuilder {
        self.desc.lobe = Some(lobe);
        self
    }

    /// Sets the accuracy tier that [`Scene::evaluate`] runs ([`SceneDesc::tier`]).
    pub fn tier(mut self, tier: Tier) -> SceneBuilder {
        self.desc.tier = tier;
        self
    }

    /// Sets how the media's in-scattered light combines along a ray
    /// ([`SceneDesc::composition`], default [`Composition::Mix`]).
    pub fn composition(mut self, composition: Composition) -> SceneBuilder {
        self.desc.composition = composition;
        self
    }

    /// The description built so far (for inspection, or for serialization with the
    /// `serde` feature).
    pub fn desc(&self) -> &SceneDesc {
        &self.desc
    }

    /// The description built so far, unvalidated.
    pub fn into_desc(self) -> SceneDesc {
        self.desc
    }

    /// Validates and compiles the scene with [`Scene::new`]: the first invalid value is
    /// returned as a [`SceneError`] whose [`field`](SceneError::field) is its path in the
    /// description, the same as for the scene loaded from JSON.
    pub fn build(self) -> Result<Scene, SceneError> {
        Scene::new(self.desc)
    }
}

impl From<SceneDesc> for SceneBuilder {
    fn from(desc: SceneDesc) -> SceneBuilder {
        SceneBuilder::from_desc(desc)
    }
}

impl From<SceneBuilder> for SceneDesc {
    fn from(builder: SceneBuilder) -> SceneDesc {
        builder.into_desc()
    }
}

/// Shorthands for the builder's [`SceneBuilder::layer`].
impl Component {
    /// A component that scatters with the given phase function and absorbs nothing.
    pub fn new(scattering: Vec3, phase: Phase) -> Component {
        Component {
            scattering,
            absorption: Vec3::ZERO,
            phase,
        }
    }

    /// A component that scatters isotropically and absorbs nothing.
    pub fn isotropic(scattering: Vec3) -> Component {
        Component::new(scattering, Phase::Isotropic)
    }

    /// This component with the given absorption coefficient (RGB, ≥ 0).
    pub fn with_absorption(mut self, absorption: Vec3) -> Component {
        self.absorption = absorption;
        self
    }
}
