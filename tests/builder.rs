//! `SceneBuilder`: a builder scene is the same scene as its `SceneDesc` literal (same
//! description, same results bit for bit), and invalid values give the typed `SceneError`
//! naming the field, exactly as `Scene::new` (and, with the `serde` feature, the JSON
//! loader) does.

use analytic_fog::{
    Component, DistanceFog, Falloff, FogLimits, HeightFogLayer, Lighting, Lobe, Outputs, Phase,
    Profile, Rays, Scene, SceneBuilder, SceneDesc, SceneError, Shape, Sun, Tier, Volume,
};
use glam::Vec3;

/// A scene using every builder method, and the same scene as a literal.
fn full_builder() -> SceneBuilder {
    SceneBuilder::new()
        .up(Vec3::new(0.1, 1.0, -0.05))
        .height_fog(HeightFogLayer {
            base_height: -2.0,
            falloff: 0.05,
            components: vec![
                Component::new(Vec3::new(0.005, 0.01, 0.02), Phase::Rayleigh),
                Component::new(Vec3::splat(0.01), Phase::HenyeyGreenstein(0.8))
                    .with_absorption(Vec3::splat(0.002)),
            ],
            emission: Vec3::new(0.01, 0.0, 0.02),
        })
        .layer(
            10.0,
            -0.02,
            Component::isotropic(Vec3::new(0.003, 0.004, 0.005)),
        )
        .ambient(Vec3::new(0.4, 0.5, 0.6))
        .sun(Vec3::new(0.3, 0.5, -0.8), Vec3::new(15.0, 14.0, 12.0))
        .volume(Volume::new(
            Shape::Sphere {
                center: Vec3::new(0.0, 3.0, 40.0),
                radius: 8.0,
            },
            Profile::Quadratic,
            Vec3::splat(0.08),
        ))
        .volume(Volume::cut(Shape::Sphere {
            center: Vec3::new(0.0, 3.0, 36.0),
            radius: 3.0,
        }))
        .distance_fog(DistanceFog {
            falloff: Falloff::Exponential { density: 0.004 },
            colour: Vec3::new(0.6, 0.7, 0.8),
        })
        .start_distance(1.5)
        .cutoff_distance(250.0)
        .max_opacity(0.95)
        .lobe(Lobe {
            colour: Vec3::new(1.0, 0.9, 0.7),
            exponent: 8.0,
        })
        .tier(Tier::Fast)
}

fn full_literal() -> SceneDesc {
    SceneDesc {
        up: Vec3::new(0.1, 1.0, -0.05),
        height_fog: vec![
            HeightFogLayer {
                base_height: -2.0,
                falloff: 0.05,
                components: vec![
                    Component {
                        scattering: Vec3::new(0.005, 0.01, 0.02),
                        absorption: Vec3::ZERO,
                        phase: Phase::Rayleigh,
                    },
                    Component {
                        scattering: Vec3::splat(0.01),
                        absorption: Vec3::splat(0.002),
                        phase: Phase::HenyeyGreenstein(0.8),
                    },
                ],
                emission: Vec3::new(0.01, 0.0, 0.02),
            },
            HeightFogLayer {
                base_height: 10.0,
                falloff: -0.02,
                components: vec![Component {
                    scattering: Vec3::new(0.003, 0.004, 0.005),
                    absorption: Vec3::ZERO,
                    phase: Phase::Isotropic,
                }],
                emission: Vec3::ZERO,
            },
        ],
        lighting: Lighting {
            ambient: Vec3::new(0.4, 0.5, 0.6),
            sun: Some(Sun {
                direction: Vec3::new(0.3, 0.5, -0.8),
                radiance: Vec3::new(15.0, 14.0, 12.0),
            }),
        },
        volumes: vec![
            Volume {
                shape: Shape::Sphere {
                    center: Vec3::new(0.0, 3.0, 40.0),
                    radius: 8.0,
                },
                profile: Profile::Quadratic,
                scattering: Vec3::splat(0.08),
                absorption: Vec3::ZERO,
                phase: Phase::Isotropic,
                emission: Vec3::ZERO,
                subtractive: false,
            },
            Volume {
                shape: Shape::Sphere {
                    center: Vec3::new(0.0, 3.0, 36.0),
                    radius: 3.0,
                },
                profile: Profile::Constant,
                scattering: Vec3::ZERO,
                absorption: Vec3::ZERO,
                phase: Phase::Isotropic,
                emission: Vec3::ZERO,
                subtractive: true,
            },
        ],
        tier: Tier::Fast,
        distance_fog: Some(DistanceFog {
            falloff: Falloff::Exponential { density: 0.004 },
            colour: Vec3::new(0.6, 0.7, 0.8),
        }),
        limits: FogLimits {
            start_distance: 1.5,
            cutoff_distance: Some(250.0),
            max_opacity: 0.95,
        },
        lobe: Some(Lobe {
            colour: Vec3::new(1.0, 0.9, 0.7),
            exponent: 8.0,
        }),
        // Fields added after this test was written keep their defaults, as in the builder.
        ..SceneDesc::default()
    }
}

/// τ, T and L_in of a batch, as bits.
fn results(scene: &Scene, rays: &[(Vec3, Vec3, f32)]) -> Vec<[u32; 9]> {
    let n = rays.len();
    let col = |f: &dyn Fn(&(Vec3, Vec3, f32)) -> f32| rays.iter().map(f).collect::<Vec<f32>>();
    let (ox, oy, oz) = (col(&|r| r.0.x), col(&|r| r.0.y), col(&|r| r.0.z));
    let (dx, dy, dz) = (col(&|r| r.1.x), col(&|r| r.1.y), col(&|r| r.1.z));
    let t = col(&|r| r.2);
    let rays = Rays::new(&ox, &oy, &oz, &dx, &dy, &dz, &t).unwrap();
    let mut b = vec![vec![0.0f32; n]; 9];
    {
        let [a0, a1, a2, b0, b1, b2, c0, c1, c2] = &mut b[..] else {
            unreachable!()
        };
        let out = Outputs {
            tau: Some([a0, a1, a2]),
            transmittance: Some([b0, b1, b2]),
            inscattering: Some([c0, c1, c2]),
        };
        scene.evaluate(&rays, out).unwrap();
    }
    (0..n)
        .map(|i| core::array::from_fn(|k| b[k][i].to_bits()))
        .collect()
}

fn test_rays() -> Vec<(Vec3, Vec3, f32)> {
    vec![
        (Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, -0.1, 1.0), 100.0),
        (Vec3::new(0.0, 3.0, 0.0), Vec3::new(0.0, 0.0, 1.0), 80.0),
        (Vec3::new(5.0, 1.0, -3.0), Vec3::new(0.3, 0.5, -0.8), 500.0),
        (Vec3::new(-20.0, 0.5, 10.0), Vec3::new(0.6, 0.05, 0.8), 1e4),
        (Vec3::new(0.0, 50.0, 0.0), Vec3::new(0.0, -1.0, 0.2), 60.0),
        (Vec3::new(1.0, 2.0, 3.0), Vec3::new(-0.2, 0.1, 0.9), 1.0),
        (Vec3::new(0.0, 3.0, 20.0), Vec3::new(0.0, 0.0, 2.0), 30.0),
        (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), 0.0),
        (Vec3::new(3.0, 4.0, 5.0), Vec3::new(0.0, 1.0, 0.0), 300.0),
    ]
}

#[test]
fn builder_scene_equals_literal() {
    let built = full_builder().build().unwrap();
    let literal = Scene::new(full_literal()).unwrap();
    assert_eq!(built.desc(), &full_literal());
    assert_eq!(full_builder().desc(), &full_literal());
    assert_eq!(built.tier(), Tier::Fast);
    assert!(built.has_directional_light());

    let rays = test_rays();
    let (a, b) = (results(&built, &rays), results(&literal, &rays));
    assert_eq!(a, b);
    // The scene is not trivially empty: fog on the first ray.
    let t_r = f32::from_bits(a[0][3]);
    assert!(t_r > 0.0 && t_r < 1.0, "T = {t_r}");
    for &(o, d, t) in &rays {
        let (x, y) = (built.eval_ray(o, d, t), literal.eval_ray(o, d, t));
        assert_eq!(
            x.tau.to_array().map(f32::to_bits),
            y.tau.to_array().map(f32::to_bits)
        );
        assert_eq!(
            x.transmittance.to_array().map(f32::to_bits),
            y.transmittance.to_array().map(f32::to_bits)
        );
        assert_eq!(
            x.inscattering.to_array().map(f32::to_bits),
            y.inscattering.to_array().map(f32::to_bits)
        );
    }
}

#[test]
fn empty_builder_is_default_desc() {
    assert_eq!(SceneBuilder::new().desc(), &SceneDesc::default());
    assert_eq!(SceneBuilder::default(), SceneBuilder::new());
    let scene = SceneBuilder::new().build().unwrap();
    let s = scene.eval_ray(Vec3::ZERO, Vec3::X, 100.0);
    assert_eq!(s.transmittance, Vec3::ONE);
    assert_eq!(s.inscattering, Vec3::ZERO);
}

#[test]
fn setters_replace_and_adders_append() {
    let c = |s: f32| Component::isotropic(Vec3::splat(s));
    let desc = SceneBuilder::new()
        .sun(Vec3::X, Vec3::ONE)
        .ambient(Vec3::splat(0.1))
        .sun(Vec3::Y, Vec3::splat(2.0))
        .layer(0.0, 0.1, c(0.01))
        .layer(1.0, 0.2, c(0.02))
        .up(Vec3::X)
        .up(Vec3::Z)
        .limits(FogLimits {
            start_distance: 3.0,
            cutoff_distance: None,
            max_opacity: 0.5,
        })
        .cutoff_distance(9.0)
        .tier(Tier::Fast)
        .tier(Tier::Accurate)
        .into_desc();
    assert_eq!(desc.up, Vec3::Z);
    assert_eq!(desc.lighting.ambient, Vec3::splat(0.1));
    assert_eq!(
        desc.lighting.sun,
        Some(Sun {
            direction: Vec3::Y,
            radiance: Vec3::splat(2.0)
        })
    );
    let heights: Vec<(f32, f32)> = desc
        .height_fog
        .iter()
        .map(|l| (l.base_height, l.falloff))
        .collect();
    assert_eq!(heights, [(0.0, 0.1), (1.0, 0.2)]);
    assert_eq!(desc.height_fog[1].components, vec![c(0.02)]);
    assert_eq!(
        desc.limits,
        FogLimits {
            start_distance: 3.0,
            cutoff_distance: Some(9.0),
            max_opacity: 0.5
        }
    );
    assert_eq!(desc.tier, Tier::Accurate);

    // `lighting` replaces both parts.
    let desc = SceneBuilder::new()
        .sun(Vec3::Y, Vec3::ONE)
        .lighting(Lighting::default())
        .into_desc();
    assert_eq!(desc.lighting, Lighting::default());

    // Conversions both ways keep the description.
    let back: SceneDesc = SceneBuilder::from(full_literal()).into();
    assert_eq!(back, full_literal());
    assert_eq!(SceneBuilder::from_desc(full_literal()), full_builder());
}

/// The builder's error for `b`, checked to be the one `Scene::new` gives for its
/// description.
fn build_err(b: SceneBuilder) -> SceneError {
    let via_new = Scene::new(b.desc().clone()).unwrap_err();
    let err = b.build().unwrap_err();
    // Not `assert_eq!(err, via_new)`: a NaN value is never equal to itself.
    assert_eq!(
        core::mem::discriminant(&err),
        core::mem::discriminant(&via_new)
    );
    assert_eq!(err.field(), via_new.field());
    assert_eq!(err.to_string(), via_new.to_string());
    err
}

fn haze() -> Component {
    Component::new(Vec3::splat(0.02), Phase::HenyeyGreenstein(0.7))
}

#[test]
fn nan_falloff() {
    let err = build_err(
        SceneBuilder::new()
            .layer(0.0, 0.1, haze())
            .layer(0.0, f32::NAN, haze()),
    );
    assert_eq!(err.field(), "height_fog[1].falloff");
    assert!(
        matches!(err, SceneError::NonFinite { value, .. } if value.is_nan()),
        "{err:?}"
    );
}

#[test]
fn negative_scattering() {
    let err = build_err(SceneBuilder::new().layer(0.0, 0.08, haze()).layer(
        5.0,
        0.2,
        Component::isotropic(Vec3::new(0.01, -0.2, 0.01)),
    ));
    assert_eq!(err.field(), "height_fog[1].components[0].scattering[1]");
    assert_eq!(
        err,
        SceneError::Negative {
            field: "height_fog[1].components[0].scattering[1]".into(),
            value: -0.2
        }
    );
    assert_eq!(
        err.to_string(),
        "height_fog[1].components[0].scattering[1]: must be >= 0, got -0.2"
    );

    let err = build_err(SceneBuilder::new().layer(
        0.0,
        0.08,
        haze().with_absorption(Vec3::new(0.0, 0.0, -1.0)),
    ));
    assert_eq!(err.field(), "height_fog[0].components[0].absorption[2]");
    assert!(matches!(err, SceneError::Negative { value, .. } if value == -1.0));
}

#[test]
fn zero_sun_direction() {
    let err = build_err(
        SceneBuilder::new()
            .layer(0.0, 0.08, haze())
            .sun(Vec3::ZERO, Vec3::ONE),
    );
    assert_eq!(err.field(), "lighting.sun.direction");
    assert_eq!(
        err,
        SceneError::ZeroVector {
            field: "lighting.sun.direction".into()
        }
    );
}

#[test]
fn zero_up() {
    let err = build_err(SceneBuilder::new().up(Vec3::ZERO).layer(0.0, 0.08, haze()));
    assert_eq!(err.field(), "up");
    assert_eq!(err, SceneError::ZeroVector { field: "up".into() });
}

#[test]
fn zero_radius_volume() {
    let sphere = |radius| Shape::Sphere {
        center: Vec3::new(0.0, 0.0, 10.0),
        radius,
    };
    let err = build_err(
        SceneBuilder::new()
            .volume(Volume::new(sphere(2.0), Profile::Constant, Vec3::ONE))
            .volume(Volume::new(sphere(0.0), Profile::Gaussian, Vec3::ONE)),
    );
    assert_eq!(err.field(), "volumes[1].shape.radius");
    assert!(
        matches!(err, SceneError::OutOfRange { value, .. } if value == 0.0),
        "{err:?}"
    );
}

#[test]
fn invalid_controls() {
    let err = build_err(SceneBuilder::new().max_opacity(1.5));
    assert_eq!(err.field(), "limits.max_opacity");
    assert!(matches!(err, SceneError::OutOfRange { value, .. } if value == 1.5));

    let err = build_err(SceneBuilder::new().cutoff_distance(-1.0));
    assert_eq!(err.field(), "limits.cutoff_distance");
    assert!(matches!(err, SceneError::Negative { .. }));

    let err = build_err(SceneBuilder::new().start_distance(f32::INFINITY));
    assert_eq!(err.field(), "limits.start_distance");
    assert!(matches!(err, SceneError::NonFinite { .. }));

    let err = build_err(SceneBuilder::new().layer(0.0, 0.1, haze()).lobe(Lobe {
        colour: Vec3::ONE,
        exponent: 4.0,
    }));
    assert_eq!(
        err,
        SceneError::Requires {
            field: "lobe".into(),
            requires: "lighting.sun"
        }
    );

    let err = build_err(SceneBuilder::new().distance_fog(DistanceFog {
        falloff: Falloff::Linear {
            start: 10.0,
            end: 5.0,
        },
        colour: Vec3::ONE,
    }));
    assert_eq!(err.field(), "distance_fog.falloff.linear.end");
    assert!(matches!(err, SceneError::OutOfRange { .. }));

    let err = build_err(SceneBuilder::new().height_fog(HeightFogLayer {
        base_height: 0.0,
        falloff: 0.1,
        components: vec![],
        emission: Vec3::ZERO,
    }));
    assert_eq!(
        err,
        SceneError::Empty {
            field: "height_fog[0].components".into()
        }
    );
}

/// The error is a typed `std::error::Error`: it goes through `?` into a boxed error and
/// comes back out as a `SceneError`.
#[test]
fn error_is_std_error() {
    fn build() -> Result<Scene, Box<dyn std::error::Error + Send + Sync>> {
        Ok(SceneBuilder::new().up(Vec3::ZERO).build()?)
    }
    let e = build().unwrap_err();
    let scene_err = e.downcast_ref::<SceneError>().expect("a SceneError");
    assert_eq!(scene_err.field(), "up");
    assert_eq!(e.to_string(), "up: must be a non-zero vector");
}

/// The builder names the same field as the JSON loader for the same scene.
#[cfg(feature = "serde")]
#[test]
fn same_errors_as_json() {
    let cases: [(SceneBuilder, &str); 4] = [
        (
            SceneBuilder::new()
                .layer(0.0, 0.08, Component::isotropic(Vec3::splat(0.02)))
                .layer(5.0, 0.2, Component::isotropic(Vec3::new(0.01, -0.2, 0.01))),
            r#"{"height_fog": [
                {"base_height": 0, "falloff": 0.08, "components": [{"scattering": 0.02}]},
                {"base_height": 5, "falloff": 0.2, "components": [{"scattering": [0.01, -0.2, 0.01]}]}
            ]}"#,
        ),
        (
            SceneBuilder::new().sun(Vec3::ZERO, Vec3::ONE),
            r#"{"lighting": {"sun": {"direction": [0, 0, 0], "radiance": 1}}}"#,
        ),
        (SceneBuilder::new().up(Vec3::ZERO), r#"{"up": [0, 0, 0]}"#),
        (
            SceneBuilder::new().volume(Volume::new(
                Shape::Sphere {
                    center: Vec3::ZERO,
                    radius: 0.0,
                },
                Profile::Constant,
                Vec3::ONE,
            )),
            r#"{"volumes": [{"shape": {"sphere": {"center": [0, 0, 0], "radius": 0}}, "scattering": 1}]}"#,
        ),
    ];
    for (builder, json) in cases {
        let desc: SceneDesc = serde_json::from_str(json).unwrap();
        assert_eq!(builder.desc(), &desc, "{json}");
        let from_json = Scene::new(desc).unwrap_err();
        assert_eq!(builder.build().unwrap_err(), from_json, "{json}");
    }
}
