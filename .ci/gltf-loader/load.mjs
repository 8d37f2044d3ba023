// Loads a file `morphlod export` wrote with three.js's GLTFLoader, as a web client would, and
// checks what the client gets:
//
//   node load.mjs FILE EXPECTED_JSON
//
// EXPECTED_JSON: {"name": "face", "targets": 12, "normalTargets": true,
//                 "lods": [{"vertices": 1234, "indices": 6000}, ...]}
//
// Every LOD node `<name>_LOD<i>` (LOD0 in the scene, the others only in the node list: three.js
// ignores MSFT_lod) is a mesh whose geometry has the vertex and index counts the writer wrote and
// one POSITION (and NORMAL) morph attribute per target; each animation clip that drives weights
// drives every LOD's morphTargetInfluences (played on all LODs at once, they all move, in step
// with LOD0); and for a skinned file, how many skinned LODs the node clips move ("skinMoved").
// Prints one JSON line; exits 1 when a check fails or the file does not load.
//
// Node has no image decoding (three.js loads images through the DOM or createImageBitmap): a
// plugin answers every texture with an empty THREE.Texture, so everything else loads as in a
// browser.
import { readFile } from "node:fs/promises";
import * as THREE from "three";
import { parse } from "./parse.mjs";

const [file, expectedJson] = process.argv.slice(2);
const expected = JSON.parse(expectedJson);
const problems = [];
const check = (ok, what) => {
  if (!ok) problems.push(what);
};

let summary = {};
try {
  const gltf = await parse(await readFile(file));
  const lods = [];
  for (let i = 0; i < expected.lods.length; i++) {
    const name = `${expected.name}_LOD${i}`;
    const index = gltf.parser.json.nodes.findIndex((n) => n.name === name);
    check(index >= 0, `no node named ${name}`);
    if (index < 0) continue;
    const node = await gltf.parser.getDependency("node", index);
    const mesh = node.isMesh ? node : node.getObjectByProperty("isMesh", true);
    check(mesh, `${name}: no mesh`);
    if (!mesh) continue;
    const g = mesh.geometry;
    const want = expected.lods[i];
    const morph = g.morphAttributes;
    const got = {
      vertices: g.attributes.position.count,
      normals: g.attributes.normal ? g.attributes.normal.count : 0,
      indices: g.index ? g.index.count : 0,
      positionTargets: (morph.position || []).length,
      normalTargets: (morph.normal || []).length,
      influences: (mesh.morphTargetInfluences || []).length,
      // A skinned LOD: its skeleton's bones, and the vertices its skin attributes bind.
      bones: mesh.isSkinnedMesh ? mesh.skeleton.bones.length : 0,
      skinned: g.attributes.skinIndex && g.attributes.skinWeight ? g.attributes.skinWeight.count : 0,
    };
    check(got.vertices === want.vertices, `${name}: ${got.vertices} vertices, wrote ${want.vertices}`);
    check(got.indices === want.indices, `${name}: ${got.indices} indices, wrote ${want.indices}`);
    check(got.positionTargets === expected.targets, `${name}: ${got.positionTargets} POSITION targets of ${expected.targets}`);
    const normalTargets = expected.normalTargets ? expected.targets : 0;
    check(got.normalTargets === normalTargets, `${name}: ${got.normalTargets} NORMAL targets, expected ${normalTargets}`);
    check(got.influences === expected.targets, `${name}: ${got.influences} morphTargetInfluences`);
    for (const [k, attr] of Object.entries(morph)) {
      for (const a of attr) check(a.count === got.vertices, `${name}: a ${k} target of ${a.count} vertices`);
    }
    lods.push({ name, mesh, got });
  }
  check(gltf.scene.getObjectByName(`${expected.name}_LOD0`), "LOD0 is not in the scene");

  // Each clip that drives weights drives every LOD: play it on all LODs under one root and
  // sample it.
  let driven = 0;
  if (expected.targets > 0 && lods.length > 0) {
    const clips = gltf.animations.filter((c) => c.tracks.some((t) => t.name.endsWith(".morphTargetInfluences")));
    check(clips.length >= 1, `${gltf.animations.length} animation clips, none drives morphTargetInfluences`);
    const root = new THREE.Group();
    for (const { mesh } of lods) root.add(mesh);
    const moved = lods.map(() => false);
    for (const clip of clips) {
      for (const { name } of lods) {
        const tracks = clip.tracks.filter((t) => t.name === `${name}.morphTargetInfluences`);
        check(tracks.length === 1, `${name}: ${tracks.length} morphTargetInfluences tracks in clip ${clip.name}`);
      }
      const rest = lods.map(({ mesh }) => [...mesh.morphTargetInfluences]);
      const mixer = new THREE.AnimationMixer(root);
      mixer.clipAction(clip).play();
      for (let s = 0; s <= 16; s++) {
        mixer.setTime((clip.duration * s) / 16);
        const first = lods[0].mesh.morphTargetInfluences;
        lods.forEach(({ name, mesh }, i) => {
          const w = mesh.morphTargetInfluences;
          check(w.every((x, k) => x === first[k]), `${name}: influences [${w}] at step ${s} of ${clip.name}, LOD0 has [${first}]`);
          if (w.some((x, k) => x !== rest[i][k])) moved[i] = true;
        });
      }
      mixer.stopAllAction();
      mixer.uncacheRoot(root);
    }
    lods.forEach(({ name }, i) => check(moved[i], `${name}: no animation changes its morphTargetInfluences`));
    driven = moved.filter((m) => m).length;
  }
  // Each clip that moves nodes moves the skinned LODs' vertices: played on the whole scene, a
  // skinned LOD's vertex 0 (skinned on the CPU by three) is somewhere else at some time.
  let skinMoved = 0;
  const jointClips = gltf.animations.filter((c) => c.tracks.some((t) => /\.(position|quaternion|scale)$/.test(t.name)));
  const skinnedLods = lods.filter(({ mesh }) => mesh.isSkinnedMesh);
  if (jointClips.length > 0 && skinnedLods.length > 0) {
    const moved = skinnedLods.map(() => false);
    for (const clip of jointClips) {
      const mixer = new THREE.AnimationMixer(gltf.scene);
      mixer.clipAction(clip).play();
      // The bones are the scene's nodes (the LODs share them); the LOD meshes are updated too.
      const at = (time) => {
        mixer.setTime(time);
        gltf.scene.updateMatrixWorld(true);
        return skinnedLods.map(({ mesh }) => {
          mesh.updateMatrixWorld(true);
          return mesh.getVertexPosition(0, new THREE.Vector3());
        });
      };
      const start = at(0);
      for (let s = 1; s <= 8; s++) {
        at((clip.duration * s) / 9).forEach((p, i) => {
          if (p.distanceTo(start[i]) > 1e-6) moved[i] = true;
        });
      }
      mixer.stopAllAction();
    }
    skinMoved = moved.filter((m) => m).length;
  }
  // Node transform channels (position, quaternion, scale tracks), for sources that animate them.
  const transformTracks = gltf.animations
    .flatMap((clip) => clip.tracks)
    .filter((t) => /\.(position|quaternion|scale)$/.test(t.name))
    .map((t) => t.name);
  summary = { lods: lods.map(({ name, got }) => ({ name, ...got })), driven, skinMoved, animations: gltf.animations.map((c) => c.name), transformTracks };
} catch (e) {
  problems.push(`could not load: ${e && e.stack ? e.stack : e}`);
}
console.log(JSON.stringify({ file, ok: problems.length === 0, problems: problems.slice(0, 20), ...summary }));
process.exit(problems.length === 0 ? 0 : 1);
