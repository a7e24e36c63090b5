// Plays a sylva .glb's wind clip with three.js (GLTFLoader and AnimationMixer in Node) and
// measures how far the skinned tree moves (issue 24): the vertex with the largest y in
// the bind pose (the tip) and the one with the smallest y (the trunk base), over every
// SkinnedMesh of the scene, are skinned (SkinnedMesh.getVertexPosition: bones and
// bind matrices applied) and taken to world space at t = 0 and t = T/4 (T the clip's
// duration).
// Usage: node wind.mjs FILE.glb [HEIGHT]
// Prints one JSON line {file, joints, clips, duration, meshes, tip_move, base_move,
// height, relative}: `joints` the skeleton's bone count, `tip_move` / `base_move` the
// distances the tip / base moved between t = 0 and T/4, `height` HEIGHT or, without it,
// the bind pose's tip y − base y, and `relative` tip_move / height. Exit 1 on a failure
// (no skinned mesh, no clip, a file that does not load). The loader setup is load.mjs's.
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

const [path, heightArg] = process.argv.slice(2);
if (!path) {
  console.error("usage: node wind.mjs FILE.glb [HEIGHT]");
  process.exit(2);
}

try {
  const bytes = readFileSync(path);
  const buf = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  const gltf = await new GLTFLoader().setMeshoptDecoder(MeshoptDecoder).parseAsync(buf, "");
  const scene = gltf.scene;
  const skinned = [];
  scene.traverse((o) => {
    if (o.isSkinnedMesh) skinned.push(o);
  });
  if (skinned.length === 0) throw new Error("no SkinnedMesh in the scene");
  if (gltf.animations.length === 0) throw new Error("no animation clip");
  const clip = gltf.animations[0];
  const skeleton = skinned[0].skeleton;

  // Tip and base: the bind-pose vertices of largest and smallest y.
  const raw = new THREE.Vector3();
  let tip = null;
  let base = null;
  for (const mesh of skinned) {
    const pos = mesh.geometry.attributes.position;
    for (let i = 0; i < pos.count; i++) {
      raw.fromBufferAttribute(pos, i);
      if (tip === null || raw.y > tip.y) tip = { mesh, i, y: raw.y };
      if (base === null || raw.y < base.y) base = { mesh, i, y: raw.y };
    }
  }

  const mixer = new THREE.AnimationMixer(scene);
  mixer.clipAction(clip).play();
  const at = (t) => {
    mixer.setTime(t);
    scene.updateMatrixWorld(true);
    for (const mesh of skinned) mesh.skeleton.update();
    const world = (v) => v.mesh.getVertexPosition(v.i, new THREE.Vector3()).applyMatrix4(v.mesh.matrixWorld);
    return { tip: world(tip), base: world(base) };
  };
  const a = at(0);
  const b = at(clip.duration / 4);
  const tipMove = a.tip.distanceTo(b.tip);
  const baseMove = a.base.distanceTo(b.base);
  const height = heightArg !== undefined ? Number(heightArg) : tip.y - base.y;
  console.log(
    JSON.stringify({
      file: path,
      joints: skeleton.bones.length,
      clips: gltf.animations.map((c) => c.name),
      duration: clip.duration,
      meshes: skinned.length,
      tip_move: tipMove,
      base_move: baseMove,
      height,
      relative: height > 0 ? tipMove / height : null,
    }),
  );
} catch (e) {
  console.log(JSON.stringify({ file: path, error: String(e) }));
  process.exit(1);
}
