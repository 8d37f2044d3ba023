// three.js's GLTFLoader parsing a file's bytes under node, as a web client would, for the
// harnesses beside this file. Node has no image decoding (three.js loads images through the DOM
// or createImageBitmap): a plugin answers every texture with an empty THREE.Texture, so
// everything else loads as in a browser. `setup(loader)` may register more (a meshopt decoder).
import * as THREE from "three";
import { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";

export function parse(bytes, setup = () => {}) {
  const loader = new GLTFLoader();
  setup(loader);
  loader.register(() => ({
    name: "morphlod_textures_undecoded",
    loadTexture: () => Promise.resolve(new THREE.Texture()),
  }));
  const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  return new Promise((resolve, reject) => loader.parse(buffer, "", resolve, reject));
}
