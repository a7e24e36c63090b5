// Loads .glb files with three.js's GLTFLoader in Node and checks what a game artist
// relies on (issue 23): the bark material with its colour, normal, roughness and
// occlusion maps, leaf cards alpha-tested, every mesh with positions and normals.
// Node has no image decoder: createImageBitmap is stubbed (the PNG bytes are read as a
// Blob, their size taken from the IHDR chunk), so textures are created but not decoded.
// Usage: node load.mjs FILE.glb... ; prints one JSON line per file; exit 1 on a failure.
import { readFileSync } from "node:fs";
import * as THREE from "three";
import { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";

globalThis.self = globalThis;
globalThis.createImageBitmap = async (blob) => {
  const b = new Uint8Array(await blob.arrayBuffer());
  const png = b[1] === 0x50 && b[2] === 0x4e && b[3] === 0x47;
  if (!png) throw new Error("not a PNG");
  const dv = new DataView(b.buffer, b.byteOffset);
  return { width: dv.getUint32(16), height: dv.getUint32(20), close() {} };
};
if (!globalThis.navigator) globalThis.navigator = { userAgent: "node" };

let failed = false;
for (const path of process.argv.slice(2)) {
  const bytes = readFileSync(path);
  const buf = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  try {
    const gltf = await new GLTFLoader().parseAsync(buf, "");
    const materials = {};
    let meshes = 0;
    gltf.scene.traverse((o) => {
      if (!o.isMesh) return;
      meshes += 1;
      if (!o.geometry.attributes.position || !o.geometry.attributes.normal) throw new Error(`${o.name}: no position/normal`);
      const m = o.material;
      materials[m.name] = {
        map: !!m.map, normalMap: !!m.normalMap, roughnessMap: !!m.roughnessMap, aoMap: !!m.aoMap,
        alphaTest: m.alphaTest, transparent: m.transparent, side: m.side,
        tangent: !!o.geometry.attributes.tangent,
      };
    });
    const extras = gltf.scene.userData?.sylva ? "recipe" : "none";
    console.log(JSON.stringify({ file: path, meshes, materials, extras }));
  } catch (e) {
    failed = true;
    console.log(JSON.stringify({ file: path, error: String(e) }));
  }
}
process.exit(failed ? 1 : 0);
