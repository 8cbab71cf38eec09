/** The workspace surface (`workspace.stl`, alpha shape of the collision-free points), translucent. */
import { FrontSide, Mesh, MeshPhongMaterial } from "three";
import { STLLoader } from "three/examples/jsm/loaders/STLLoader.js";

export function buildWorkspaceMesh(stl: ArrayBuffer): Mesh {
  const geometry = new STLLoader().parse(stl);
  const material = new MeshPhongMaterial({
    color: 0x3fa7d6,
    transparent: true,
    opacity: 0.18,
    depthWrite: false,
    // The STL has outward normals (Contract 2): the outer shell is enough for a translucent surface and
    // halves the fill cost of this screen-filling mesh.
    side: FrontSide,
  });
  const mesh = new Mesh(geometry, material);
  mesh.name = "workspace surface";
  mesh.renderOrder = 2; // after opaque geometry and the points
  return mesh;
}

export function triangleCount(mesh: Mesh): number {
  const pos = mesh.geometry.getAttribute("position");
  return pos ? pos.count / 3 : 0;
}
