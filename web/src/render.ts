// Drawing with WebGL2: each entity's mesh (uploaded once per entity) lit
// by a sun and a sky fill, with a metre grid on static scenery, seen by an
// orbit camera. The lighting is the native viewer's
// (`shaders/wgsl/viewer_scene.wgsl`), in GLSL.

import type { EntityKind } from "./control.js";
import type { Mesh } from "./mesh.js";

export interface Pose {
  position: [number, number, number];
  rotation: [number, number, number, number];
}

export interface Item {
  id: number;
  mesh: Mesh;
  /** sRGB bytes, RGBA. */
  color: [number, number, number, number];
  kind: EntityKind;
  pose: Pose;
}

const SKY = [0.42, 0.56, 0.78];

const VERTEX = `#version 300 es
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
uniform mat4 view_proj;
uniform mat4 model;
out vec3 world;
out vec3 n;
void main() {
  vec4 w = model * vec4(position, 1.0);
  world = w.xyz;
  n = mat3(model) * normal;
  gl_Position = view_proj * w;
}`;

const FRAGMENT = `#version 300 es
precision highp float;
in vec3 world;
in vec3 n;
uniform vec4 color;
uniform vec3 eye;
uniform int gridded;
out vec4 out_color;
vec3 to_srgb(vec3 c) {
  return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}
void main() {
  vec3 normal = normalize(n);
  if (!gl_FrontFacing) normal = -normal;
  vec3 base = color.rgb;
  if (gridded == 1) {
    vec3 a = abs(normal);
    vec2 plane = a.x > a.y && a.x > a.z ? world.zy : (a.z > a.y ? world.xy : world.xz);
    vec2 cell = floor(plane);
    float checker = abs(mod(cell.x + cell.y, 2.0));
    vec2 ten = abs(fract(plane / 10.0 + 0.5) - 0.5) * 10.0;
    vec2 width = max(fwidth(plane) * 1.5, vec2(1e-4));
    float line = 1.0 - min(min(ten.x / width.x, ten.y / width.y), 1.0);
    float fade = exp(-length(eye - world) * 0.015);
    base *= 1.0 + (checker * 0.12 - line * 0.3) * fade;
  }
  vec3 sun = normalize(vec3(0.45, 0.8, 0.3));
  float diffuse = max(dot(normal, sun), 0.0);
  vec3 fill = mix(vec3(0.10, 0.09, 0.08), vec3(0.28, 0.32, 0.40), 0.5 + 0.5 * normal.y);
  vec3 to_eye = normalize(eye - world);
  float spec = pow(max(dot(normal, normalize(sun + to_eye)), 0.0), 48.0) * 0.2 * step(0.0, diffuse);
  vec3 lit = base * (fill + diffuse * vec3(1.0, 0.95, 0.85)) + vec3(spec);
  float fog = 1.0 - exp(-length(eye - world) * 0.004);
  lit = mix(lit, vec3(${SKY.join(", ")}), fog);
  out_color = vec4(to_srgb(lit), color.a);
}`;

/** The orbit camera: a target, a distance, yaw and pitch (rad). */
export class OrbitCamera {
  target: [number, number, number] = [0, 2, 0];
  distance = 30;
  yaw = 0.62;
  pitch = 0.38;

  eye(): [number, number, number] {
    const c = Math.cos(this.pitch);
    return [
      this.target[0] + Math.sin(this.yaw) * c * this.distance,
      this.target[1] + Math.sin(this.pitch) * this.distance,
      this.target[2] + Math.cos(this.yaw) * c * this.distance,
    ];
  }

  orbit(dx: number, dy: number): void {
    this.yaw -= dx * 0.005;
    this.pitch = Math.min(Math.max(this.pitch + dy * 0.005, -1.55), 1.55);
  }

  zoom(steps: number): void {
    this.distance = Math.min(Math.max(this.distance * 0.9 ** steps, 0.5), 500);
  }

  /** World to clip space, column-major, for a picture `aspect` wide. */
  viewProj(aspect: number): Float32Array {
    const eye = this.eye();
    const f = normalize(sub(this.target, eye));
    const s = normalize(cross(f, [0, 1, 0]));
    const u = cross(s, f);
    const view = [
      s[0], u[0], -f[0], 0,
      s[1], u[1], -f[1], 0,
      s[2], u[2], -f[2], 0,
      -dot(s, eye), -dot(u, eye), dot(f, eye), 1,
    ];
    const near = 0.05;
    const far = 2000;
    const t = 1 / Math.tan(0.9 / 2);
    const proj = [
      t / aspect, 0, 0, 0,
      0, t, 0, 0,
      0, 0, (far + near) / (near - far), -1,
      0, 0, (2 * far * near) / (near - far), 0,
    ];
    return Float32Array.from(multiply(proj, view));
  }
}

type V3 = [number, number, number];
const sub = (a: V3, b: V3): V3 => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const dot = (a: V3, b: V3): number => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a: V3, b: V3): V3 => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const normalize = (a: V3): V3 => {
  const n = Math.hypot(...a) || 1;
  return [a[0] / n, a[1] / n, a[2] / n];
};

/** a × b, column-major 4×4. */
function multiply(a: number[], b: number[]): number[] {
  const out = new Array<number>(16).fill(0);
  for (let c = 0; c < 4; c++) {
    for (let r = 0; r < 4; r++) {
      let s = 0;
      for (let k = 0; k < 4; k++) {
        s += (a[k * 4 + r] ?? 0) * (b[c * 4 + k] ?? 0);
      }
      out[c * 4 + r] = s;
    }
  }
  return out;
}

/** The frame of `pose`, column-major. */
function modelOf(pose: Pose): Float32Array {
  const [x, y, z, w] = pose.rotation;
  const [px, py, pz] = pose.position;
  return Float32Array.from([
    1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w), 0,
    2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w), 0,
    2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y), 0,
    px, py, pz, 1,
  ]);
}

function linear(c: number): number {
  const s = c / 255;
  return s <= 0.04045 ? s / 12.92 : ((s + 0.055) / 1.055) ** 2.4;
}

interface Uploaded {
  vao: WebGLVertexArrayObject;
  vertices: WebGLBuffer;
  indices: WebGLBuffer;
  count: number;
  mesh: Mesh;
}

export class Renderer {
  readonly camera = new OrbitCamera();
  private readonly gl: WebGL2RenderingContext;
  private readonly program: WebGLProgram;
  private readonly uploaded = new Map<number, Uploaded>();
  private readonly u: Record<string, WebGLUniformLocation | null>;

  constructor(private readonly canvas: HTMLCanvasElement) {
    const gl = canvas.getContext("webgl2", { antialias: true, preserveDrawingBuffer: true });
    if (!gl) {
      throw new Error("this browser has no WebGL2");
    }
    this.gl = gl;
    const shader = (kind: number, src: string): WebGLShader => {
      const s = gl.createShader(kind);
      if (!s) throw new Error("no shader");
      gl.shaderSource(s, src);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) {
        throw new Error(`shader: ${gl.getShaderInfoLog(s)}`);
      }
      return s;
    };
    const program = gl.createProgram();
    if (!program) throw new Error("no program");
    gl.attachShader(program, shader(gl.VERTEX_SHADER, VERTEX));
    gl.attachShader(program, shader(gl.FRAGMENT_SHADER, FRAGMENT));
    gl.linkProgram(program);
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) {
      throw new Error(`program: ${gl.getProgramInfoLog(program)}`);
    }
    this.program = program;
    this.u = Object.fromEntries(
      ["view_proj", "model", "color", "eye", "gridded"].map((n) => [n, gl.getUniformLocation(program, n)]),
    );
  }

  /** The entity's mesh on the GPU: uploaded once, and again into the
   * same buffers when the item brings another mesh (a soft body's, made
   * every frame). */
  private upload(item: Item): Uploaded {
    const gl = this.gl;
    let up = this.uploaded.get(item.id);
    if (up && up.mesh === item.mesh) {
      return up;
    }
    if (!up) {
      const vao = gl.createVertexArray();
      const vertices = gl.createBuffer();
      const indices = gl.createBuffer();
      if (!vao || !vertices || !indices) throw new Error("no vertex array");
      gl.bindVertexArray(vao);
      gl.bindBuffer(gl.ARRAY_BUFFER, vertices);
      gl.enableVertexAttribArray(0);
      gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 24, 0);
      gl.enableVertexAttribArray(1);
      gl.vertexAttribPointer(1, 3, gl.FLOAT, false, 24, 12);
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, indices);
      gl.bindVertexArray(null);
      up = { vao, vertices, indices, count: 0, mesh: item.mesh };
      this.uploaded.set(item.id, up);
    }
    const usage = up.count > 0 ? gl.DYNAMIC_DRAW : gl.STATIC_DRAW;
    gl.bindVertexArray(up.vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, up.vertices);
    gl.bufferData(gl.ARRAY_BUFFER, item.mesh.vertices, usage);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, item.mesh.indices, usage);
    gl.bindVertexArray(null);
    up.count = item.mesh.indices.length;
    up.mesh = item.mesh;
    return up;
  }

  /** Frees the GPU copy of an entity's mesh (it left). */
  private forget(id: number): void {
    const up = this.uploaded.get(id);
    if (up) {
      this.gl.deleteVertexArray(up.vao);
      this.gl.deleteBuffer(up.vertices);
      this.gl.deleteBuffer(up.indices);
      this.uploaded.delete(id);
    }
  }

  /** Draws `items` (opaque first, then see-through) filling the canvas. */
  draw(items: Item[]): void {
    const gl = this.gl;
    const w = Math.max(1, Math.floor(this.canvas.clientWidth * devicePixelRatio));
    const h = Math.max(1, Math.floor(this.canvas.clientHeight * devicePixelRatio));
    if (this.canvas.width !== w || this.canvas.height !== h) {
      this.canvas.width = w;
      this.canvas.height = h;
    }
    gl.viewport(0, 0, w, h);
    const srgb = SKY.map((c) => (c <= 0.0031308 ? c * 12.92 : 1.055 * c ** (1 / 2.4) - 0.055));
    gl.clearColor(srgb[0] ?? 0, srgb[1] ?? 0, srgb[2] ?? 0, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.disable(gl.CULL_FACE);
    gl.useProgram(this.program);
    gl.uniformMatrix4fv(this.u.view_proj ?? null, false, this.camera.viewProj(w / h));
    gl.uniform3fv(this.u.eye ?? null, this.camera.eye());
    const translucent = (i: Item): boolean => i.kind === "Water" || i.color[3] < 253;
    const ordered = [...items.filter((i) => !translucent(i)), ...items.filter(translucent)];
    for (const item of ordered) {
      if (item.mesh.indices.length === 0) {
        continue;
      }
      const see = translucent(item);
      if (see) {
        gl.enable(gl.BLEND);
        gl.blendFunc(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA);
        gl.depthMask(false);
      } else {
        gl.disable(gl.BLEND);
        gl.depthMask(true);
      }
      const up = this.upload(item);
      gl.uniformMatrix4fv(this.u.model ?? null, false, modelOf(item.pose));
      const [r, g, b, a] = item.color;
      gl.uniform4f(this.u.color ?? null, linear(r), linear(g), linear(b), a / 255);
      gl.uniform1i(this.u.gridded ?? null, item.kind === "Static" && !see ? 1 : 0);
      gl.bindVertexArray(up.vao);
      gl.drawElements(gl.TRIANGLES, up.count, gl.UNSIGNED_INT, 0);
    }
    gl.bindVertexArray(null);
    gl.depthMask(true);
    // Entities no longer drawn (they left) free their GPU copies.
    const live = new Set(items.map((i) => i.id));
    for (const id of [...this.uploaded.keys()]) {
      if (!live.has(id)) {
        this.forget(id);
      }
    }
  }
}
