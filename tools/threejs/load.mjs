// Loads .glb files with three.js's GLTFLoader in Node and checks what a game artist
// relies on (issue 23): the bark material with its colour, normal, roughness and
// occlusion maps, leaf cards alpha-tested, every mesh with positions and normals.
// Node has no image decoder: createImageBitmap is stubbed (the PNG bytes are read as a
// Blob, their size taken from the IHDR chunk), so textures are created but not decoded.
// Instanced leaves (EXT_mesh_gpu_instancing) load as InstancedMesh: `instances` counts
// their copies. EXT_meshopt_compression is decoded with three's MeshoptDecoder.
// `bounds` holds each mesh's world-space box (every instance included), [min, max].
// Usage: node load.mjs FILE.glb... ; prints one JSON line per file; exit 1 on a failure.
import { readFileSync } from "node:fs";
import * as THREE from "three";
import { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";
import { MeshoptDecoder } from "three/examples/jsm/libs/meshopt_decoder.module.js";

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
    const gltf = await new GLTFLoader().setMeshoptDecoder(MeshoptDecoder).parseAsync(buf, "");
    const materials = {};
    let meshes = 0;
    let instances = 0;
    const bounds = {};
    gltf.scene.updateMatrixWorld(true);
    gltf.scene.traverse((o) => {
      if (!o.isMesh) return;
      meshes += 1;
      if (o.isInstancedMesh) instances += o.count;
      if (!o.geometry.attributes.position || !o.geometry.attributes.normal) throw new Error(`${o.name}: no position/normal`);
      const box = new THREE.Box3();
      const p = new THREE.Vector3();
      const xf = new THREE.Matrix4();
      const pos = o.geometry.attributes.position;
      for (let i = 0; i < (o.isInstancedMesh ? o.count : 1); i++) {
        if (o.isInstancedMesh) {
          o.getMatrixAt(i, xf);
          xf.premultiply(o.matrixWorld);
        }
        else xf.copy(o.matrixWorld);
        for (let k = 0; k < pos.count; k++) box.expandByPoint(p.fromBufferAttribute(pos, k).applyMatrix4(xf));
      }
      bounds[o.name] = [box.min.toArray(), box.max.toArray()];
      const m = o.material;
      materials[m.name] = {
        map: !!m.map, normalMap: !!m.normalMap, roughnessMap: !!m.roughnessMap, aoMap: !!m.aoMap,
        alphaTest: m.alphaTest, transparent: m.transparent, side: m.side,
        tangent: !!o.geometry.attributes.tangent,
      };
    });
    const extras = gltf.scene.userData?.sylva ? "recipe" : "none";
    console.log(JSON.stringify({ file: path, meshes, instances, materials, extras, bounds }));
  } catch (e) {
    failed = true;
    console.log(JSON.stringify({ file: path, error: String(e) }));
  }
}
process.exit(failed ? 1 : 0);
