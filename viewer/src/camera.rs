//! The orbit camera: it looks at a target point from a distance, turned by
//! yaw and pitch; drag to orbit, scroll to zoom, and optionally follow a
//! body (the player's avatar).

use glam::{Mat4, Vec3};

/// Vertical field of view, rad.
const FOV_Y: f32 = 0.9;
/// Near and far clip distances, m.
const NEAR: f32 = 0.05;
const FAR: f32 = 2000.0;
/// How far the camera may come in and go out, m.
const MIN_DISTANCE: f32 = 0.5;
const MAX_DISTANCE: f32 = 500.0;
/// The pitch stays this far from straight up or down, rad.
const PITCH_LIMIT: f32 = 1.55;

/// Where the camera is and what it looks at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrbitCamera {
    /// The point looked at, m.
    pub target: Vec3,
    /// Distance from the target, m.
    pub distance: f32,
    /// Turn about +Y, rad (0 looks along −Z).
    pub yaw: f32,
    /// Angle above the horizon, rad.
    pub pitch: f32,
}

impl Default for OrbitCamera {
    /// A view of the demo scene: the middle of the arena from above and
    /// to the south.
    fn default() -> Self {
        Self {
            target: Vec3::new(0.0, 2.0, 0.0),
            distance: 34.0,
            yaw: 0.55,
            pitch: 0.42,
        }
    }
}

impl OrbitCamera {
    /// Looking at the default target from `yaw` and `pitch` (rad) at
    /// `distance` (m), each kept in its range.
    pub fn looking(yaw: f32, pitch: f32, distance: f32) -> Self {
        Self {
            yaw,
            pitch: pitch.clamp(-PITCH_LIMIT, PITCH_LIMIT),
            distance: distance.clamp(MIN_DISTANCE, MAX_DISTANCE),
            ..Self::default()
        }
    }

    /// The camera's position, m.
    pub fn eye(&self) -> Vec3 {
        let back = Vec3::new(
            self.yaw.sin() * self.pitch.cos(),
            self.pitch.sin(),
            self.yaw.cos() * self.pitch.cos(),
        );
        self.target + back * self.distance
    }

    /// World to clip space for a picture `aspect` wide (width / height),
    /// with wgpu's depth range 0..1.
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        // wgpu's clip space is Direct3D's: depth 0 to 1, Y up.
        let view = glam::camera::rh::view::look_at_mat4(self.eye(), self.target, Vec3::Y);
        let proj = glam::camera::rh::proj::directx::perspective(FOV_Y, aspect.max(1e-3), NEAR, FAR);
        proj * view
    }

    /// Turns by a drag of (`dx`, `dy`) pixels.
    pub fn orbit(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx * 0.005;
        self.pitch = (self.pitch + dy * 0.005).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// Moves the target in the view plane by a drag of (`dx`, `dy`) pixels.
    pub fn pan(&mut self, dx: f32, dy: f32) {
        let forward = (self.target - self.eye()).normalize_or(Vec3::NEG_Z);
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        let up = right.cross(forward);
        let scale = self.distance * 0.0015;
        self.target += (-right * dx + up * dy) * scale;
    }

    /// Comes in (`steps` > 0) or goes out, by 10 % a step.
    pub fn zoom(&mut self, steps: f32) {
        self.distance = (self.distance * 0.9f32.powf(steps)).clamp(MIN_DISTANCE, MAX_DISTANCE);
    }

    /// Moves the target smoothly towards `point` (m) over about `dt` /
    /// 0.15 s, as when following a body.
    pub fn follow(&mut self, point: Vec3, dt: f32) {
        let k = 1.0 - (-dt / 0.15).exp();
        self.target += (point - self.target) * k.clamp(0.0, 1.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_target_projects_to_the_middle_of_the_picture() {
        let cam = OrbitCamera::default();
        let clip = cam.view_proj(16.0 / 9.0) * cam.target.extend(1.0);
        let ndc = clip.truncate() / clip.w;
        assert!(ndc.x.abs() < 1e-5 && ndc.y.abs() < 1e-5, "{ndc}");
        assert!(ndc.z > 0.0 && ndc.z < 1.0);
    }

    #[test]
    fn the_eye_is_at_its_distance_and_above_the_ground() {
        let cam = OrbitCamera::default();
        assert!(((cam.eye() - cam.target).length() - cam.distance).abs() < 1e-4);
        assert!(cam.eye().y > cam.target.y);
    }

    #[test]
    fn orbiting_never_flips_over_the_pole_and_zoom_stays_in_range() {
        let mut cam = OrbitCamera::default();
        cam.orbit(0.0, 1e6);
        assert!(cam.pitch <= PITCH_LIMIT);
        cam.zoom(1e3);
        assert_eq!(cam.distance, MIN_DISTANCE);
        cam.zoom(-1e3);
        assert_eq!(cam.distance, MAX_DISTANCE);
        assert!(cam.view_proj(1.0).is_finite());
    }

    #[test]
    fn following_closes_in_on_the_point_without_overshooting() {
        let mut cam = OrbitCamera::default();
        let goal = Vec3::new(10.0, 1.0, -4.0);
        let mut last = (cam.target - goal).length();
        for _ in 0..120 {
            cam.follow(goal, 1.0 / 60.0);
            let d = (cam.target - goal).length();
            assert!(d <= last);
            last = d;
        }
        assert!(last < 0.01, "{last}");
    }
}
