// Loads a compressed file `morphlod export --compress` wrote with three.js's GLTFLoader and the
// MeshoptDecoder three ships (three/examples/jsm/libs/meshopt_decoder.module.js, no other
// package), as a web client would, and prints what the client decoded for every LOD node:
//
//   node decode.mjs FILE NAME LODS
//
// One JSON line: {"lods": [{"name", "translation", "scale", "index": {"type", "base64"},
// "position": {...}, "morphPosition": [...], "morphNormal": [...]}, ...]}, each array's bytes
// as three holds them (little-endian, as the typed arrays store them), so the caller compares
// them bit for bit.
// Exits 1 when the file does not load or a LOD node is missing.
import { readFile } from "node:fs/promises";
import { parse } from "./parse.mjs";
import { MeshoptDecoder } from "three/examples/jsm/libs/meshopt_decoder.module.js";

const [file, name, count] = process.argv.slice(2);

// The attribute's components as stored (no normalization applied), packed one element after
// the other, whether three keeps them interleaved (a strided view) or not.
function dump(attribute) {
  const source = attribute.isInterleavedBufferAttribute ? attribute.data.array : attribute.array;
  const stride = attribute.isInterleavedBufferAttribute ? attribute.data.stride : attribute.itemSize;
  const offset = attribute.isInterleavedBufferAttribute ? attribute.offset : 0;
  const packed = new source.constructor(attribute.count * attribute.itemSize);
  for (let i = 0; i < attribute.count; i++) {
    for (let k = 0; k < attribute.itemSize; k++) {
      packed[i * attribute.itemSize + k] = source[i * stride + offset + k];
    }
  }
  return {
    type: source.constructor.name,
    normalized: attribute.normalized,
    base64: Buffer.from(packed.buffer).toString("base64"),
  };
}

try {
  await MeshoptDecoder.ready;
  const gltf = await parse(await readFile(file), (loader) => loader.setMeshoptDecoder(MeshoptDecoder));
  const lods = [];
  for (let i = 0; i < Number(count); i++) {
    const lodName = `${name}_LOD${i}`;
    const index = gltf.parser.json.nodes.findIndex((n) => n.name === lodName);
    if (index < 0) throw new Error(`no node named ${lodName}`);
    const node = await gltf.parser.getDependency("node", index);
    const mesh = node.isMesh ? node : node.getObjectByProperty("isMesh", true);
    if (!mesh) throw new Error(`${lodName}: no mesh`);
    const g = mesh.geometry;
    lods.push({
      name: lodName,
      translation: node.position.toArray(),
      scale: node.scale.toArray(),
      index: g.index ? dump(g.index) : null,
      position: dump(g.attributes.position),
      morphPosition: (g.morphAttributes.position || []).map(dump),
      morphNormal: (g.morphAttributes.normal || []).map(dump),
    });
  }
  console.log(JSON.stringify({ ok: true, lods }));
} catch (e) {
  console.log(JSON.stringify({ ok: false, error: String(e && e.stack ? e.stack : e) }));
  process.exit(1);
}
