// The three.js classes the offline viewer uses, bundled by vendor.sh into one classic script
// (../three.min.js) that sets the global THREE: a page opened from file:// may not load ES modules.
export {
  AxesHelper, Box3, BufferAttribute, BufferGeometry, Color, DirectionalLight, Group,
  HemisphereLight, Matrix3, Matrix4, Mesh, MeshStandardMaterial, PerspectiveCamera,
  PMREMGenerator, REVISION, Raycaster, SRGBColorSpace, Scene, Sphere, Vector2, Vector3,
  WebGLRenderer,
} from 'three';
export { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
export { RoomEnvironment } from 'three/examples/jsm/environments/RoomEnvironment.js';
