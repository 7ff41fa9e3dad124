// The viewer's scene: lit, instanced meshes, and a metre grid on scenery.
//
// One directional light (the sun) with a sky/ground hemisphere fill and a
// little specular, then distance fog towards the sky colour. Colours are
// linear; the target is an sRGB texture, which encodes them on write.
// Triangles are drawn from both sides: a back face turns its normal round.

struct Camera {
    // World to clip space.
    view_proj: mat4x4<f32>,
    // The camera's position, m (w unused).
    eye: vec4<f32>,
    // Unit direction towards the sun (w unused).
    sun: vec4<f32>,
    // Sky colour, linear RGB; w: fog density, 1/m.
    sky: vec4<f32>,
};

@group(0) @binding(0) var<uniform> camera: Camera;

struct VertexIn {
    // Corner of the mesh, in the entity's frame, m.
    @location(0) position: vec3<f32>,
    // Unit normal, in the entity's frame.
    @location(1) normal: vec3<f32>,
    // The entity's frame (columns of a rotation-and-translation matrix).
    @location(2) model_0: vec4<f32>,
    @location(3) model_1: vec4<f32>,
    @location(4) model_2: vec4<f32>,
    @location(5) model_3: vec4<f32>,
    // Linear RGBA.
    @location(6) color: vec4<f32>,
};

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
};

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    let model = mat4x4<f32>(v.model_0, v.model_1, v.model_2, v.model_3);
    let world = model * vec4<f32>(v.position, 1.0);
    var out: VertexOut;
    out.clip = camera.view_proj * world;
    out.world = world.xyz;
    // The frame is a rotation: it turns normals as it turns points.
    out.normal = (model * vec4<f32>(v.normal, 0.0)).xyz;
    out.color = v.color;
    return out;
}

fn shade(base: vec3<f32>, world: vec3<f32>, normal_in: vec3<f32>, front: bool) -> vec3<f32> {
    var n = normalize(normal_in);
    if (!front) {
        n = -n;
    }
    let sun = camera.sun.xyz;
    let diffuse = max(dot(n, sun), 0.0);
    let up = 0.5 + 0.5 * n.y;
    let fill = mix(vec3<f32>(0.10, 0.09, 0.08), vec3<f32>(0.28, 0.32, 0.40), up);
    let to_eye = normalize(camera.eye.xyz - world);
    let half_way = normalize(sun + to_eye);
    let specular = pow(max(dot(n, half_way), 0.0), 48.0) * 0.2 * step(0.0, diffuse);
    let lit = base * (fill + diffuse * vec3<f32>(1.0, 0.95, 0.85)) + vec3<f32>(specular);
    let distance = length(camera.eye.xyz - world);
    let fog = 1.0 - exp(-distance * camera.sky.w);
    return mix(lit, camera.sky.rgb, fog);
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    return vec4<f32>(shade(in.color.rgb, in.world, in.normal, front), in.color.a);
}

// Static scenery (the ground, walls, posts): its colour in a checker of
// 1 m squares with darker lines every 10 m, laid on the two world axes
// across the surface's normal, faded out with distance so it does not
// shimmer.
@fragment
fn fs_gridded(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    let n = abs(normalize(in.normal));
    var plane = in.world.xz;
    if (n.x > n.y && n.x > n.z) {
        plane = in.world.zy;
    } else if (n.z > n.y) {
        plane = in.world.xy;
    }
    let cell = floor(plane);
    let checker = abs((cell.x + cell.y) % 2.0);
    let ten = abs(fract(plane / 10.0 + 0.5) - 0.5) * 10.0;
    let width = max(fwidth(plane) * 1.5, vec2<f32>(1e-4));
    let line = 1.0 - min(min(ten.x / width.x, ten.y / width.y), 1.0);
    let fade = exp(-length(camera.eye.xyz - in.world) * 0.015);
    let pattern = (checker * 0.12 - line * 0.3) * fade;
    let base = in.color.rgb * (1.0 + pattern);
    return vec4<f32>(shade(base, in.world, in.normal, front), in.color.a);
}
