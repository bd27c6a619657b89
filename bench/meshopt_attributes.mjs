// meshoptimizer's simplifyWithAttributes (the npm module) on an OBJ that
// meshreduce wrote (`meshreduce convert IN.glb OUT.obj`: one v, vt and vn
// line per vertex, faces v/vt/vn with equal indices), for a comparison at
// the same triangle count with `meshreduce compare`:
//
//   node bench/meshopt_attributes.mjs NODE_MODULES IN.obj TRIANGLES OUT.obj [FLAGS]
//
// NODE_MODULES: where `npm install meshoptimizer@1.3` put it. Normals weigh
// 0.5 and texture coordinates 1 (gltfpack's weights); the error limit is
// off (1, relative), so the count is the target. FLAGS: the simplifier's
// flags, comma-separated (Permissive, LockBorder, Prune, ...). Prints the
// triangles it reached.
import fs from 'fs';
import path from 'path';
import { pathToFileURL } from 'url';

const [modules, input, triangles, output, flagList] = process.argv.slice(2);
if (!modules || !input || !triangles || !output) {
    console.error('usage: meshopt_attributes.mjs NODE_MODULES IN.obj TRIANGLES OUT.obj [FLAGS]');
    process.exit(2);
}
const { MeshoptSimplifier } =
    await import(pathToFileURL(path.join(modules, 'meshoptimizer', 'index.js')).href);
const v = [], vt = [], vn = [], f = [];
for (const line of fs.readFileSync(input, 'utf8').split('\n')) {
    const t = line.trim().split(/\s+/);
    if (t[0] === 'v') v.push(+t[1], +t[2], +t[3]);
    else if (t[0] === 'vt') vt.push(+t[1], +t[2]);
    else if (t[0] === 'vn') vn.push(+t[1], +t[2], +t[3]);
    else if (t[0] === 'f') for (let i = 1; i <= 3; i++) f.push(parseInt(t[i].split('/')[0]) - 1);
}
const n = v.length / 3;
if (vt.length / 2 !== n || vn.length / 3 !== n) {
    console.error(`${input}: needs one vt and one vn line per v line`);
    process.exit(1);
}
await MeshoptSimplifier.ready;
const attr = new Float32Array(n * 5);
for (let i = 0; i < n; i++) {
    attr.set([vn[3 * i], vn[3 * i + 1], vn[3 * i + 2], vt[2 * i], vt[2 * i + 1]], 5 * i);
}
const flags = flagList ? flagList.split(',') : [];
const [out] = MeshoptSimplifier.simplifyWithAttributes(
    new Uint32Array(f), new Float32Array(v), 3, attr, 5, [0.5, 0.5, 0.5, 1, 1], null,
    3 * +triangles, 1.0, flags);
const lines = [];
for (let i = 0; i < n; i++) {
    lines.push(`v ${v[3 * i]} ${v[3 * i + 1]} ${v[3 * i + 2]}`, `vt ${vt[2 * i]} ${vt[2 * i + 1]}`,
               `vn ${vn[3 * i]} ${vn[3 * i + 1]} ${vn[3 * i + 2]}`);
}
for (let i = 0; i < out.length; i += 3) {
    const [a, b, c] = [out[i] + 1, out[i + 1] + 1, out[i + 2] + 1];
    lines.push(`f ${a}/${a}/${a} ${b}/${b}/${b} ${c}/${c}/${c}`);
}
fs.writeFileSync(output, lines.join('\n') + '\n');
console.log(`triangles ${out.length / 3}`);
