//! Handles everywhere: every run-time setter takes a typed id that keeps naming its object when
//! others are despawned (scene indices shift, ids do not), a stale id (despawned, or from a scene
//! loaded before) is `Error::StaleId`, and the scene file's objects are found by their `name`.

mod common;

use glam::{DMat4, DVec3};
use hadou::scene::transform::TransformOp;
use hadou::{Aov, Ball, Error, FrameRequest, WaveUpdate};

const SCENE: &str = r#"
[camera]
position = [0, 1, 9]
look_at = [0, 0, 0]
[[light]]
direction = [-0.3, -1, -0.5]
[[light]]
direction = [0.3, -1, -0.5]
color = [1, 0.5, 0.2]
[[light]]
direction = [0, -1, 0.5]
intensity = 0.5
[[mesh]]
name = "box"
kind = "cube"
[[material]]
name = "stone"
albedo = [0.5, 0.5, 0.5]
[[material]]
name = "moss"
albedo = [0.2, 0.6, 0.3]
[[instance]]
name = "a"
mesh = "box"
material = "stone"
transform = [{ translate = [-2, 0, 0] }]
[[instance]]
name = "b"
mesh = "box"
material = "moss"
[[instance]]
name = "c"
mesh = "box"
material = "stone"
transform = [{ translate = [2, 0, 0] }]
[[instance]]
name = "a"
mesh = "box"
transform = [{ translate = [0, 2, 0] }]
[[wave]]
name = "w0"
origin = [-3, 0, 0]
direction = [1, 0, 0]
a = 1.0
b = 0.5
[[wave]]
name = "w1"
origin = [0, 0, 0]
direction = [0, 1, 0]
a = 1.0
b = 0.5
[[wave]]
name = "w2"
origin = [3, 0, 0]
direction = [0, 0, 1]
a = 1.0
b = 0.5
[[metaballs]]
name = "g0"
material = "moss"
balls = [{ centre = [-2, -2, 0], radius = 1 }]
[[metaballs]]
name = "g1"
material = "moss"
balls = [{ centre = [0, -2, 0], radius = 1 }]
[[metaballs]]
name = "g2"
material = "moss"
balls = [{ centre = [2, -2, 0], radius = 1 }, { centre = [2.5, -2, 0], radius = 1 }]
"#;

/// Despawning the middle instance, wave, metaball group and light shifts the later ones down by
/// one; setting the last of each by its id changes that object (found by name in the scene) and
/// nothing else. The despawned ids and the ids of a scene loaded before are `StaleId`; a
/// material id sets that material.
#[test]
fn setters_follow_their_object_across_despawns() {
    let mut live = common::runtime();
    live.load_scene(common::parse(SCENE)).unwrap();
    let r = live.renderer();
    let [a, b, c] = ["a", "b", "c"].map(|n| r.instance_named(n).unwrap());
    let [w0, w1, w2] = ["w0", "w1", "w2"].map(|n| r.wave_named(n).unwrap());
    let [g0, g1, g2] = ["g0", "g1", "g2"].map(|n| r.metaballs_named(n).unwrap());
    let lights = r.light_ids();
    let moss = r.material_named("moss").unwrap();
    let before = r.scene().unwrap().clone();

    // Instances: b goes, c is now at index 1 and is the one that moves.
    r.despawn_instance(b).unwrap();
    let moved = DMat4::from_translation(DVec3::new(5.0, 1.0, -1.0));
    r.set_transform(c, moved).unwrap();
    let scene = r.scene().unwrap();
    let names: Vec<_> = scene.instances.iter().map(|i| i.name.as_deref()).collect();
    assert_eq!(names, [Some("a"), Some("c"), Some("a")]);
    assert_eq!(scene.instances[1].transform.matrix, moved, "c moved");
    assert_eq!(scene.instances[0], before.instances[0], "a unchanged");
    assert_eq!(scene.instances[2], before.instances[3], "the second \"a\" unchanged");
    let ops = [TransformOp::Translate(DVec3::new(0.0, 0.0, -3.0))];
    r.set_transform_ops(a, &ops).unwrap();
    let scene = r.scene().unwrap();
    assert_eq!(scene.instances[0].ops, ops);
    assert_eq!(scene.instances[1].transform.matrix, moved, "c kept");
    assert!(matches!(r.set_transform(b, moved), Err(Error::StaleId(_))));
    assert!(matches!(r.set_transform_ops(b, &ops), Err(Error::StaleId(_))));

    // Waves: w1 goes, w2 is now at index 1.
    r.despawn_wave(w1).unwrap();
    let update = WaveUpdate {
        origin: DVec3::new(1.0, 2.0, 3.0),
        direction: DVec3::new(0.0, 0.0, -2.0),
        a: 2.0,
        b: 0.25,
        length: 4.0,
    };
    r.set_wave(w2, update).unwrap();
    let scene = r.scene().unwrap();
    assert_eq!(scene.waves()[1].name.as_deref(), Some("w2"));
    assert_eq!(
        (scene.waves()[1].origin, scene.waves()[1].direction, scene.waves()[1].a, scene.waves()[1].b),
        (update.origin, DVec3::NEG_Z, 2.0, 0.25)
    );
    assert_eq!(scene.waves()[1].length, 4.0);
    assert_eq!(scene.waves()[0], before.waves()[0], "w0 unchanged");
    assert!(matches!(r.set_wave(w1, update), Err(Error::StaleId(_))));
    let _ = w0;

    // Metaball groups: g1 goes, g2 is now at index 1.
    r.despawn_metaballs(g1).unwrap();
    let balls = [Ball { centre: DVec3::new(0.0, 3.0, 0.0), radius: 0.5, q: 2.0 }];
    r.set_metaball_group(g2, &balls).unwrap();
    r.set_metaball(g2, 0, DVec3::new(0.0, 3.5, 0.0), 1.5).unwrap();
    let scene = r.scene().unwrap();
    assert_eq!(scene.metaballs()[1].name.as_deref(), Some("g2"));
    assert_eq!(scene.metaballs()[1].balls.len(), 1);
    assert_eq!(
        (scene.metaballs()[1].balls[0].centre, scene.metaballs()[1].balls[0].q),
        (DVec3::new(0.0, 3.5, 0.0), 1.5)
    );
    assert_eq!(scene.metaballs()[0], before.metaballs()[0], "g0 unchanged");
    assert!(matches!(r.set_metaball_group(g1, &balls), Err(Error::StaleId(_))));
    assert!(matches!(r.set_metaball(g1, 0, DVec3::ZERO, 1.0), Err(Error::StaleId(_))));
    assert!(matches!(
        r.set_metaball(g0, 1, DVec3::ZERO, 1.0),
        Err(Error::UnknownId { index: 1, count: 1, .. })
    ));

    // Lights: the second goes, the third is now at index 1.
    r.despawn_light(lights[1]).unwrap();
    let (color, intensity) = (DVec3::new(0.1, 0.2, 0.3), 1.5);
    r.set_light(lights[2], DVec3::new(0.0, -2.0, 0.0), color, intensity).unwrap();
    let scene = r.scene().unwrap();
    assert_eq!(scene.lights.len(), 2);
    assert_eq!(
        (scene.lights[1].direction, scene.lights[1].color, scene.lights[1].intensity),
        (DVec3::NEG_Y, color, intensity)
    );
    assert_eq!(scene.lights[0], before.lights[0], "the first light unchanged");
    assert!(matches!(r.set_light(lights[1], DVec3::NEG_Y, color, 1.0), Err(Error::StaleId(_))));

    // Materials: by id, the other one unchanged.
    r.set_material(moss, DVec3::new(0.9, 0.1, 0.1), None).unwrap();
    let scene = r.scene().unwrap();
    assert_eq!(scene.materials[1].albedo, DVec3::new(0.9, 0.1, 0.1));
    assert_eq!(scene.materials[0], before.materials[0], "stone unchanged");

    // The world still renders.
    let mut request = FrameRequest::new(32, 24);
    request.aovs = vec![Aov::Hdr, Aov::Energy];
    live.render(&request).unwrap();

    // A scene loaded again: every id of the one before is stale, a fresh lookup works.
    live.load_scene(common::parse(SCENE)).unwrap();
    let r = live.renderer();
    assert!(matches!(r.set_transform(a, moved), Err(Error::StaleId(_))));
    assert!(matches!(r.set_wave(w2, update), Err(Error::StaleId(_))));
    assert!(matches!(r.set_metaball_group(g2, &balls), Err(Error::StaleId(_))));
    assert!(matches!(r.set_light(lights[0], DVec3::NEG_Y, color, 1.0), Err(Error::StaleId(_))));
    assert!(matches!(r.set_material(moss, DVec3::ONE, None), Err(Error::StaleId(_))));
    let moss = r.material_named("moss").unwrap();
    r.set_material(moss, DVec3::ONE, None).unwrap();
    common::assert_clean(&live);
}

/// Name lookup: each kind finds its own objects (the first in scene order when names repeat),
/// a missing name, a name of another kind and a despawned object's name are `None`; spawned
/// objects have no name. An id of another renderer is `StaleId` there.
#[test]
fn objects_are_found_by_name() {
    let mut live = common::runtime();
    live.load_scene(common::parse(SCENE)).unwrap();
    let r = live.renderer();
    let instances = r.instance_ids();
    assert_eq!(r.instance_named("a"), Some(instances[0]), "the first \"a\"");
    assert_eq!(r.instance_named("c"), Some(instances[2]));
    assert_eq!(r.wave_named("w1"), Some(r.wave_ids()[1]));
    assert_eq!(r.metaballs_named("g2"), Some(r.metaballs_ids()[2]));
    assert_eq!(r.material_named("stone"), Some(r.material_ids()[0]));
    assert_eq!(r.material_named("moss"), Some(r.material_ids()[1]));
    for missing in ["no such", "", "A"] {
        assert_eq!(r.instance_named(missing), None);
        assert_eq!(r.wave_named(missing), None);
        assert_eq!(r.metaballs_named(missing), None);
        assert_eq!(r.material_named(missing), None);
    }
    assert_eq!(r.instance_named("w0"), None, "a wave's name is not an instance's");
    assert_eq!(r.wave_named("g0"), None);
    assert_eq!(r.metaballs_named("moss"), None);
    assert_eq!(r.material_named("a"), None);

    let first_a = instances[0];
    r.despawn_instance(first_a).unwrap();
    assert_eq!(r.instance_named("a"), Some(instances[3]), "the other \"a\" once the first is gone");
    r.despawn_wave(r.wave_named("w1").unwrap()).unwrap();
    assert_eq!(r.wave_named("w1"), None);
    r.despawn_metaballs(r.metaballs_named("g0").unwrap()).unwrap();
    assert_eq!(r.metaballs_named("g0"), None);
    assert_eq!(r.metaballs_named("g1"), Some(r.metaballs_ids()[0]));

    let spawned = r.spawn_instance("box", "stone", DMat4::IDENTITY).unwrap();
    assert!(r.instance_ids().contains(&spawned));
    assert_eq!(r.instance_named("box"), None, "a mesh's name is not an instance's");
    let c = r.instance_named("c").unwrap();
    let stone = r.material_named("stone").unwrap();

    // Another renderer with the same scene: its objects have ids of their own, and one of this
    // renderer's names nothing there.
    let mut other = common::runtime();
    other.load_scene(common::parse(SCENE)).unwrap();
    let o = other.renderer();
    assert_ne!(o.instance_named("c"), Some(c));
    assert!(matches!(o.set_transform(c, DMat4::IDENTITY), Err(Error::StaleId(_))));
    assert!(matches!(o.set_material(stone, DVec3::ONE, None), Err(Error::StaleId(_))));
    assert_eq!(o.scene().unwrap().instances, common::parse(SCENE).instances, "nothing changed there");
    other.finish();
    common::assert_clean(&live);
}
