/* Camera orientation: lighting estimated in the camera frame turned into world space
 * (docs/OUTPUT.md, "World space"). A pose is a rotation from the camera frame (x right, y up,
 * looking along -z: the frame of pl_light.dir) to the world frame; positions are not needed, the
 * lights are directions and distances from the camera. Quaternions are (w, x, y, z) with
 * v_world = q v_camera q*, the convention of ARKit's/ARCore's/WebXR's camera orientation. */
#ifndef PL_LIGHT_POSE_H
#define PL_LIGHT_POSE_H

#include "parlight.h"



/* The rotation turning gravity g (measured in the camera frame, pointing down, any length > 0)
 * onto world -y by the smallest angle: a gravity-aligned frame whose yaw follows the camera.
 * PL_E_ARG for a zero or non-finite g. Also returns it as a quaternion when q is not NULL. */
int pl_rotation_from_gravity(const float g[3], double R[9], double q[4]);

/* Spherical linear interpolation from a (t = 0) to b (t = 1) along the shorter arc. */
void pl_quat_slerp(const double a[4], const double b[4], double t, double out[4]);

/* v' = R v. */
void pl_rotate3(const double R[9], const float v[3], float out[3]);
/* v' = R^T v (world back to camera). */
void pl_rotate3_inverse(const double R[9], const float v[3], float out[3]);


#endif
