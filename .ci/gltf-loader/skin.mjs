// Skins a glTF file's mesh with three.js, as a web client would, and prints the positions it
// computes, for tests/suite/skin_three.rs to compare with morphlod's CPU reference:
//
//   node skin.mjs FILE MESH SAMPLES_JSON
//
// MESH: the index of the glTF mesh (its first node that three loads as a SkinnedMesh).
// SAMPLES_JSON: [{"walk": 0.25}, {"walk": 0.5, "morph": 4.0}, ...]: per sample, each named
// animation clip played by its own AnimationMixer on the scene and set to that time in seconds
// (once, clamped at its end as glTF clamps: LoopOnce, clampWhenFinished); then the scene's
// world matrices are updated and every vertex read with SkinnedMesh.getVertexPosition (the
// morph targets at the clips' morphTargetInfluences, then applyBoneTransform: the skinning three
// runs on the CPU, the same sum its shader makes) and taken to world space by the mesh's world
// matrix, as three draws it (getVertexPosition answers in the mesh's space: three's attached bind
// mode undoes the mesh's world matrix, which the renderer applies again, so the skinned mesh
// node's own transform drops out, as glTF asks).
//
// One JSON line: {"ok": true, "vertices": N, "positions": [base64 of N × 3 float32, ...]}.
// Exits 1 when the file does not load, the mesh is not skinned or a clip is missing.
import { readFile } from "node:fs/promises";
import * as THREE from "three";
import { parse } from "./parse.mjs";

const [file, meshIndex, samplesJson] = process.argv.slice(2);
const samples = JSON.parse(samplesJson);

try {
  const gltf = await parse(await readFile(file));
  const json = gltf.parser.json;
  const nodeIndex = json.nodes.findIndex((n) => n.mesh === Number(meshIndex));
  if (nodeIndex < 0) throw new Error(`no node instances mesh ${meshIndex}`);
  const association = gltf.parser.associations;
  let mesh = null;
  gltf.scene.traverse((o) => {
    const a = association.get(o);
    if (!mesh && o.isSkinnedMesh && a && a.nodes === nodeIndex) mesh = o;
  });
  if (!mesh) throw new Error(`node ${nodeIndex} is not a SkinnedMesh in the scene`);
  const mixers = new Map();
  const positions = [];
  const v = new THREE.Vector3();
  for (const sample of samples) {
    for (const [name, time] of Object.entries(sample)) {
      if (!mixers.has(name)) {
        const clip = gltf.animations.find((c) => c.name === name);
        if (!clip) throw new Error(`no animation clip ${name}`);
        const mixer = new THREE.AnimationMixer(gltf.scene);
        const action = mixer.clipAction(clip);
        action.setLoop(THREE.LoopOnce, 1);
        action.clampWhenFinished = true;
        mixers.set(name, { mixer, action });
      }
      // A clamped action pauses at its end: reset it, so every sample starts from 0.
      const { mixer, action } = mixers.get(name);
      action.reset().play();
      mixer.setTime(time);
    }
    gltf.scene.updateMatrixWorld(true);
    const count = mesh.geometry.attributes.position.count;
    const out = new Float32Array(count * 3);
    for (let i = 0; i < count; i++) {
      mesh.getVertexPosition(i, v).applyMatrix4(mesh.matrixWorld);
      out[3 * i] = v.x;
      out[3 * i + 1] = v.y;
      out[3 * i + 2] = v.z;
    }
    positions.push(Buffer.from(out.buffer).toString("base64"));
  }
  console.log(JSON.stringify({ ok: true, vertices: mesh.geometry.attributes.position.count, positions }));
} catch (e) {
  console.log(JSON.stringify({ ok: false, error: String(e && e.stack ? e.stack : e) }));
  process.exit(1);
}
