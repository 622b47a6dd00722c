#include "synthetic/pov_scene.h"

#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "model/conic.h"
#include "model/hyperboloid.h"
#include "model/lip.h"
#include "model/rig_frames.h"

namespace omni::synthetic {
namespace {

// Lip lighting: the illuminance on the lips' seen faces (a paint of reflectance 1 renders at this
// level, so the pure blue and red lips stay below 8-bit saturation, whose clipping would move their
// edges), of which kLipAmbient is the room's bounce light and the rest the lamps'.
constexpr double kLipIlluminance = 0.8;
constexpr double kLipAmbient = 0.15;

std::string Num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

// A single-mirror rig's conic (its shape block is R, K: rig_params.h).
Conic<double> SingleConic(const RigParams& rig) {
  return Conic<double>{rig.mirror1_shape[kShapeC], rig.mirror1_shape[kShapeK]};
}

std::string Vec(double x, double y, double z) {
  return "<" + Num(x) + ", " + Num(y) + ", " + Num(z) + ">";
}

// POV-Ray `matrix` of the rigid transform p -> R p + t (POV-Ray multiplies row vectors, so the
// first nine numbers are R's columns).
std::string Matrix(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  std::ostringstream s;
  s << "matrix <";
  for (int col = 0; col < 3; ++col)
    for (int row = 0; row < 3; ++row) s << Num(R(row, col)) << ", ";
  s << Num(t.x()) << ", " << Num(t.y()) << ", " << Num(t.z()) << ">";
  return s.str();
}

// The sheet (z - z0)^2/a^2 - r^2/b^2 = 1 as POV-Ray's quadric A x^2 + B y^2 + C z^2 + ... + I z + J.
std::string Quadric(const HyperboloidSheet<double>& h) {
  const double ia2 = 1 / (h.a * h.a), ib2 = 1 / (h.b * h.b);
  return "quadric { " + Vec(-ib2, -ib2, ia2) + ", <0, 0, 0>, " + Vec(0, 0, -2 * h.z0 * ia2) +
         ", " + Num(h.z0 * h.z0 * ia2 - 1) + " }";
}

// A machined mirror's surface z = Z(x, y) (conic + sag, model/mirror_profile.h) as POV-Ray
// functions declared once at the top of the scene: OmniMirror<n>P(W), the Legendre terms as one
// polynomial in W (Horner), and OmniMirror<n>S(x, y, R2) with R2 = x^2 + y^2, so that each
// evaluation computes r^2 and w once (3.3x faster than the terms written out, same image to the
// byte but 2 values of 3.7 M).
// conic: the conic's z as a POV-Ray expression in R2 (HyperboloidConicZ, SingleConicSag).
std::string ProfileFunctions(const std::string& conic, const ProfileShape& shape, const double* c,
                             int mirror) {
  // P1..P4 as monomials in W: a0 + a1 W + a2 W^2 + a3 W^3 + a4 W^4.
  const double a[5] = {-0.5 * c[1] + 0.375 * c[3], c[0] - 1.5 * c[2], 1.5 * c[1] - 3.75 * c[3],
                       2.5 * c[2], 4.375 * c[3]};
  const std::string name = "OmniMirror" + std::to_string(mirror);
  const double span = shape.r_max * shape.r_max - shape.r_min * shape.r_min;
  std::ostringstream s;
  s << "#declare " << name << "P = function(W) { " << Num(a[0]) << "+W*(" << Num(a[1]) << "+W*("
    << Num(a[2]) << "+W*(" << Num(a[3]) << "+W*" << Num(a[4]) << "))) }\n"
    << "#declare " << name << "S = function(x, y, R2) { " << conic << "+" << name << "P("
    << Num(2 / span) << "*(R2-"
    << Num(shape.r_min * shape.r_min) << ")-1)+(" << Num(c[4]) << "*(x*x-y*y)+" << Num(c[5])
    << "*2*x*y)/" << Num(shape.r_max * shape.r_max);
  if (shape.ripple_amplitude != 0) {
    s << "+" << Num(shape.ripple_amplitude) << "*sin(" << Num(2 * M_PI / shape.ripple_period)
      << "*sqrt(R2)+" << Num(shape.ripple_phase) << ")";
  }
  s << " }\n";
  return s.str();
}

// A folded rig's hyperboloid sheet's z(R2) (hyperboloid.h) for ProfileFunctions.
std::string HyperboloidConicZ(const HyperboloidSheet<double>& h) {
  return Num(h.z0) + "+" + Num(h.sheet * h.a / h.b) + "*sqrt(" + Num(h.b * h.b) + "+R2)";
}

// A single rig's conic's sag s(R2) = R2 / (R + sqrt(R^2 - (1 + K) R2)) (conic.h) for
// ProfileFunctions, measured from the vertex. Beyond an ellipsoid's or sphere's equator (only the
// corners of the isosurface's box, clipped away) the root is clamped at 0, so the function stays
// finite there.
std::string SingleConicSag(const Conic<double>& conic) {
  return "R2/(" + Num(conic.R) + "+sqrt(max(0," + Num(conic.R * conic.R) + "-(" +
         Num(1 + conic.K) + ")*R2)))";
}

// The profiled mirror as POV-Ray's isosurface of sheet * (z - Z(x, y)) (ProfileFunctions), which
// has the quadric's sign on each side of the surface near it (negative between the sheet and z0:
// the same inside/outside and textures), in a box around the mirror's radii. Exact, not a mesh.
std::string ProfiledSurface(const HyperboloidSheet<double>& h, double r_max, int mirror) {
  // |grad| <= sqrt(1 + slope^2) with the conic's slope below a/b and the profile's below 0.02.
  const double max_gradient = 1.05 * std::sqrt(1 + std::pow(h.a / h.b + 0.02, 2)) + 0.05;
  const double box = r_max + 1;
  const double z_a = h.Z(0), z_b = h.Z(r_max + 1);
  std::ostringstream s;
  s << "isosurface { function { " << Num(h.sheet) << "*(z-OmniMirror" << mirror
    << "S(x, y, x*x+y*y)) }\n"
    << "      contained_by { box { " << Vec(-box, -box, std::min(z_a, z_b) - 1) << ", "
    << Vec(box, box, std::max(z_a, z_b) + 1) << " } }\n"
    << "      threshold 0 accuracy 1e-5 max_gradient " << Num(max_gradient) << " open }";
  return s.str();
}

// A mirror sheet clipped to r_min <= r <= r_max on its own side of z0, in its body frame. The
// reflective side faces the primary focus, which POV-Ray counts as the quadric's inside (checked by
// the marker test: the camera sees interior_texture); the back is matte black.
// extra_clip: further half-spaces in the body frame (mirror 1 exists only beyond the reflex plane).
// A profile (shape.present) makes the surface ProfiledSurface's isosurface (its functions
// declared by ProfileFunctions).
std::string MirrorObject(const HyperboloidSheet<double>& h, const ProfileShape& shape, int mirror,
                         double r_min, double r_max, const std::string& extra_clip = "") {
  const double z_lo = h.z0 - 2000, z_hi = h.z0 + 2000;
  std::ostringstream s;
  s << "object { " << (shape.present ? ProfiledSurface(h, r_max, mirror) : Quadric(h))
    << "\n"
    << "    clipped_by { intersection {\n"
    << "      cylinder { " << Vec(0, 0, z_lo) << ", " << Vec(0, 0, z_hi) << ", " << Num(r_max)
    << " }\n";
  if (r_min > 0) {
    s << "      cylinder { " << Vec(0, 0, z_lo) << ", " << Vec(0, 0, z_hi) << ", " << Num(r_min)
      << " inverse }\n";
  }
  // Keep the sheet's own side: plane{n, d} keeps n . x <= d.
  s << "      plane { " << Vec(0, 0, -h.sheet) << ", " << Num(-h.sheet * h.z0) << " }\n"
    << extra_clip << "    } }\n"
    << "    texture { MatteBlack } interior_texture { MirrorFinish }\n  }";
  return s.str();
}

// A lip's paint (model/lip.h) as a matte texture: lit by the room's lamps and bounce light.
std::string LipTexture(const Lip& lip, Mirror owner) {
  const Eigen::Vector3d rgb = LipPaintOf(lip.color, owner);
  return "texture { pigment { rgb " + Vec(rgb.x(), rgb.y(), rgb.z()) + " } finish { LipPaint } }";
}

// The room's lamps (POV-Ray world, y up): the lips are the only diffuse surfaces, everything else
// is self-lit. A ring of lamps below the lips lights mirror 1's lip from below (its underside is
// what the camera sees, directly and in mirror 1), a ring above lights mirror 2's lip from above
// (seen in mirror 2 and the reflex disc). The lamps are shadowless: a room's light is soft, and a
// point lamp's hard shadow of a mirror body would cross a lip's band as a sharp edge.
// A single-mirror rig has the lower ring only, and only where its mirror has a painted lip.
std::string RoomLamps(const RigParams& rig, const SceneContent& content) {
  constexpr int kLamps = 6;
  const double radius = 0.6 * content.room_half_size_mm;
  const int rings = rig.Single() ? (HasLip(rig, Mirror::kOne) ? 1 : 0) : 2;
  std::ostringstream s;
  for (int ring = 0; ring < rings; ++ring) {
    const double lamp_z = 0.5 * (ring == 0 ? content.room_floor_mm : content.room_ceiling_mm);
    const double lip_z =
        ring == 0 ? rig.lip1.z + rig.mirror1_pose[kTz] : rig.lip2.z + rig.mirror2_pose[kTz];
    // Each lamp lights the lip at cos = height / distance to the lamp.
    const double cos_incidence = std::abs(lamp_z - lip_z) / std::hypot(radius, lamp_z - lip_z);
    const double intensity = (kLipIlluminance - kLipAmbient) / (kLamps * cos_incidence);
    for (int k = 0; k < kLamps; ++k) {
      const double a = 2 * M_PI * (k + 0.25 * (1 + ring)) / kLamps;
      s << "light_source { " << Vec(radius * std::cos(a), -radius * std::sin(a), lamp_z) << " rgb "
        << Num(intensity) << " shadowless }\n";
    }
  }
  return s.str();
}

// The mount's posts (model/mount.h) in their body's frame: matte grey square prisms.
std::string MountPosts(const Mount& mount, double grey) {
  std::ostringstream s;
  for (size_t i = 0; i < mount.azimuths.size(); ++i) {
    const double azimuth = mount.azimuths[i], h = 0.5 * mount.WidthOf(i);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(azimuth, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    s << "  box { " << Vec(mount.radius - h, -h, mount.z_min) << ", "
      << Vec(mount.radius + h, h, mount.z_max)
      << " texture { pigment { rgb " << Num(grey) << " } finish { SelfLit } } "
      << Matrix(R, Eigen::Vector3d::Zero()) << " }\n";
  }
  return s.str();
}

// Both mirror bodies in C: the hyperboloids (with their profiles), the reflex disc, the lips and
// the mount's posts, each body's union posed by its cam_from_mirror.
std::string MirrorBodies(const RigParams& rig, double post_grey) {
  std::ostringstream s;
  const Pose<double> cam_from_m1 = PoseFromBlock(rig.mirror1_pose.data());
  const Pose<double> cam_from_m2 = PoseFromBlock(rig.mirror2_pose.data());
  const auto m1 = HyperboloidSheet<double>::Mirror1(rig.mirror1_shape[kShapeC], rig.mirror1_shape[kShapeK]);
  const auto m2 = HyperboloidSheet<double>::Mirror2(rig.mirror2_shape[kShapeC], rig.mirror2_shape[kShapeK], rig.d);
  const Plane<double> reflex = ReflexPlaneInMirror1(rig.reflex.data(), rig.d);
  // Mirror 1's body: the hyperboloid from r_ref out to r_sys, the reflex disc, the blue lip.
  // Mirror 1's surface is kept where it lies beyond the reflex plane (as RigModel assumes):
  // plane{n, n.p} keeps (x - p).n <= 0, the side away from the camera.
  const std::string beyond_reflex = "      plane { " +
      Vec(reflex.normal.x(), reflex.normal.y(), reflex.normal.z()) + ", " +
      Num(reflex.normal.dot(reflex.point)) + " }\n";
  s << "  union {  // mirror 1 body (frame M1)\n"
    << "  " << MirrorObject(m1, rig.profile1, 1, 0.0, rig.r_sys, beyond_reflex)
    << "\n"
    << "  disc { " << Vec(reflex.point.x(), reflex.point.y(), reflex.point.z()) << ", "
    << Vec(reflex.normal.x(), reflex.normal.y(), reflex.normal.z()) << ", " << Num(rig.r_ref)
    << " texture { MirrorFinish } }\n"
    << "  disc { " << Vec(0, 0, rig.lip1.z) << ", <0, 0, 1>, " << Num(rig.lip1.r_outer) << ", "
    << Num(rig.lip1.r_inner) << " " << LipTexture(rig.lip1, Mirror::kOne) << " }\n"
    << (rig.mount.present && rig.mount.body == Mirror::kOne ? MountPosts(rig.mount, post_grey) : "")
    << "  " << Matrix(cam_from_m1.rotation, cam_from_m1.translation) << "\n  }\n";
  s << "  union {  // mirror 2 body (frame M2), with the camera hole of radius r_cam\n"
    << "  " << MirrorObject(m2, rig.profile2, 2, rig.r_cam, rig.r_sys)
    << "\n"
    << "  disc { " << Vec(0, 0, rig.lip2.z) << ", <0, 0, 1>, " << Num(rig.lip2.r_outer) << ", "
    << Num(rig.lip2.r_inner) << " " << LipTexture(rig.lip2, Mirror::kTwo) << " }\n"
    << (rig.mount.present && rig.mount.body == Mirror::kTwo ? MountPosts(rig.mount, post_grey) : "")
    << "  " << Matrix(cam_from_m2.rotation, cam_from_m2.translation) << "\n  }\n";
  return s.str();
}

// A single-mirror rig's conic (conic_sheet.h), clipped to its used annulus r_cam..r_sys and to
// the branch through the vertex (R - (1 + K) s > 0), in a frame with the vertex at the origin
// (s = z). The quadric r^2 - 2 R s + (1 + K) s^2, like the profile's isosurface of
// s(x, y) - z, is negative on the mirror body's side and positive on the camera's, so the
// camera sees the outside: the texture is the mirror, the interior texture matte black.
std::string SingleMirrorSurface(const RigParams& rig) {
  const Conic<double> conic = SingleConic(rig);
  const double one_k = 1 + conic.K;
  const double r_box = rig.r_sys + 1;
  // The conic's top within the box's radius (an ellipsoid or sphere closes at its equator).
  const double s_top = conic.Covers(r_box * r_box) ? conic.Sag(r_box * r_box) : conic.R / one_k;
  std::ostringstream s;
  if (rig.profile1.present) {
    // |grad| <= sqrt(1 + slope^2), the conic's slope largest at the box's radius (or the rim's,
    // for a conic that closes before it) and the profile's below 0.02 (ProfiledSurface).
    const double r_slope = conic.Covers(r_box * r_box) ? r_box : rig.r_sys;
    const double slope = r_slope * conic.SlopeOverRadius(r_slope * r_slope);
    const double max_gradient = 1.05 * std::sqrt(1 + std::pow(slope + 0.02, 2)) + 0.05;
    s << "isosurface { function { OmniMirror1S(x, y, x*x+y*y)-z }\n"
      << "      contained_by { box { " << Vec(-r_box, -r_box, -1) << ", "
      << Vec(r_box, r_box, s_top + 1) << " } }\n"
      << "      threshold 0 accuracy 1e-5 max_gradient " << Num(max_gradient) << " open }";
  } else {
    s << "quadric { <1, 1, " << Num(one_k) << ">, <0, 0, 0>, " << Vec(0, 0, -2 * conic.R)
      << ", 0 }";
  }
  const std::string surface = s.str();
  s.str("");
  const double z_far = 2 * (s_top + rig.r_sys) + 10;
  s << "object { " << surface << "\n"
    << "    clipped_by { intersection {\n"
    << "      cylinder { " << Vec(0, 0, -z_far) << ", " << Vec(0, 0, z_far) << ", "
    << Num(rig.r_sys) << " }\n";
  if (rig.r_cam > 0) {
    s << "      cylinder { " << Vec(0, 0, -z_far) << ", " << Vec(0, 0, z_far) << ", "
      << Num(rig.r_cam) << " inverse }\n";
  }
  // The other branch lies beyond the conic's centre s = R / (1 + K) (none for a paraboloid);
  // plane{n, d} keeps n . x <= d.
  if (std::abs(one_k) > 1e-9 && !rig.profile1.present) {
    const double sign = one_k > 0 ? 1 : -1;
    s << "      plane { " << Vec(0, 0, sign) << ", " << Num(sign * conic.R / one_k) << " }\n";
  }
  s << "    } }\n"
    << "    texture { MirrorFinish } interior_texture { MatteBlack }\n"
    << "    translate " << Vec(0, 0, rig.vertex_z) << "\n  }";
  return s.str();
}

// A single-mirror rig's body in C: the mirror, the camera's own reflection inside r_cam (a dark
// centre, as in photographs), a dark housing ring just outside the rim (the rim's edge is what
// a user and `init` find in a photo), a painted lip where the model has one, the mount's posts.
std::string SingleMirrorBody(const RigParams& rig, double post_grey) {
  const Pose<double> cam_from_m1 = PoseFromBlock(rig.mirror1_pose.data());
  const Conic<double> conic = SingleConic(rig);
  const double rim_z = rig.vertex_z + conic.Sag(rig.r_sys * rig.r_sys);
  const double housing = std::max(2.0, 0.1 * rig.r_sys);
  // A painted lip lies on the rim where the housing would (coplanar discs would fight): the
  // housing then starts outside the lip.
  const double housing_inner =
      HasLip(rig, Mirror::kOne) ? std::max(rig.r_sys, rig.lip1.r_outer) : rig.r_sys;
  std::ostringstream s;
  s << "  union {  // the single mirror's body (frame M1)\n"
    << "  " << SingleMirrorSurface(rig) << "\n";
  if (rig.r_cam > 0) {
    s << "  disc { " << Vec(0, 0, rig.vertex_z + conic.Sag(rig.r_cam * rig.r_cam))
      << ", <0, 0, 1>, " << Num(rig.r_cam) << " texture { MatteBlack } }\n";
  }
  s << "  disc { " << Vec(0, 0, rim_z) << ", <0, 0, 1>, " << Num(housing_inner + housing) << ", "
    << Num(housing_inner) << " texture { Housing } }\n";
  if (HasLip(rig, Mirror::kOne)) {
    s << "  disc { " << Vec(0, 0, rig.lip1.z) << ", <0, 0, 1>, " << Num(rig.lip1.r_outer) << ", "
      << Num(rig.lip1.r_inner) << " " << LipTexture(rig.lip1, Mirror::kOne) << " }\n";
  }
  s << (rig.mount.present && rig.mount.body == Mirror::kOne ? MountPosts(rig.mount, post_grey) : "")
    << "  " << Matrix(cam_from_m1.rotation, cam_from_m1.translation) << "\n  }\n";
  return s.str();
}

// One target sheet in C: a chessboard of boxes, or a box with the tag texture's PNG.
std::string TargetObject(const TargetSheet& sheet) {
  std::ostringstream s;
  const TargetSpec& spec = sheet.spec;
  const Eigen::Vector4d bounds = SheetBounds(spec);  // x0, y0, x1, y1
  const std::string pose =
      Matrix(sheet.cam_from_target_rotation, sheet.cam_from_target_translation);
  if (spec.type == TargetType::kChessboard) {
    const double sq = spec.square_mm;
    // Squares span [-sq, cols*sq] x [-sq, rows*sq] on a white sheet (SheetBounds).
    s << "  union {  // chessboard " << spec.rows << "x" << spec.cols << " inner corners\n"
      << "    box { " << Vec(-sq, -sq, 0) << ", " << Vec(spec.cols * sq, spec.rows * sq, 0.5)
      << "\n      pigment { checker rgb 0, rgb 1 scale " << Num(sq) << " translate "
      << Vec(0, 0, 0.5 * sq) << " } finish { SelfLit } }\n"
      << "    box { " << Vec(bounds[0], bounds[1], 0.01) << ", " << Vec(bounds[2], bounds[3], 2)
      << " pigment { rgb 1 } finish { SelfLit } }\n"
      << "    " << pose << "\n  }\n";
    return s.str();
  }
  // image_map puts the PNG on the unit square with its top row at y = 1; the texture's top row
  // must lie at y0 (y runs down the printed face), hence the negative y scale. No `interpolate`:
  // every texel is a sharp square, so tag edges fall exactly on the texel boundaries.
  const double w = bounds[2] - bounds[0], h = bounds[3] - bounds[1];
  s << "  box {  // " << TargetTypeName(spec.type) << " " << spec.rows << "x" << spec.cols
    << " tags\n"
    << "    " << Vec(bounds[0], bounds[1], 0) << ", " << Vec(bounds[2], bounds[3], 0.5) << "\n"
    << "    pigment { image_map { png \"" << sheet.texture << "\" once }\n"
    << "      scale " << Vec(w, -h, 1) << " translate " << Vec(bounds[0], bounds[3], 0)
    << " }\n"
    << "    finish { SelfLit }\n"
    << "    " << pose << "\n  }\n";
  return s.str();
}

// The room's walls around everything (plain grey, or granite with dots for texture).
std::string RoomObject(const SceneContent& content) {
  std::ostringstream s;
  if (content.room && content.room_plain) {
    const double L = content.room_half_size_mm;
    s << "  box { " << Vec(-L, -L, content.room_floor_mm) << ", "
      << Vec(L, L, content.room_ceiling_mm) << " hollow\n"
      << "    texture { pigment { rgb 0.45 } finish { SelfLit } } }\n";
  } else if (content.room) {
    const double L = content.room_half_size_mm;
    const Eigen::Vector3d& o = content.room_texture_offset_mm;
    s << "  box { " << Vec(-L, -L, content.room_floor_mm) << ", "
      << Vec(L, L, content.room_ceiling_mm) << " hollow\n"
      << "    texture { pigment { granite color_map { [0 rgb 0.05] [0.3 rgb <0.8, 0.5, 0.2>] "
         "[0.6 rgb <0.2, 0.6, 0.9>] [1 rgb 0.95] } scale 400 translate "
      << Vec(o.x(), o.y(), o.z()) << " }\n"
      << "      finish { SelfLit } }\n"
      << "    texture { pigment { bozo color_map { [0 rgbt 1] [0.5 rgbt 1] [0.5 rgb 0.1] "
         "[1 rgb 0.9] } scale 60 translate " << Vec(o.x(), o.y(), o.z())
      << " } finish { SelfLit } } }\n";
  }

  return s.str();
}

// POV-Ray's camera for the rig's lens (the header's convention). Perspective: right, up and
// direction (a, b, 1) as derived in PovSceneText. Telecentric (orthographic): POV-Ray starts
// pixel (i, j)'s ray at location + x_s right + y_s up (the same screen coordinates as the
// perspective camera) and sends it along direction; with the same right and up and location
// (a, b, 0) that origin is (x_mm, -y_mm, 0) for the pixel-centre convention
// u = fx x_mm + s y_mm + cx, v = fy y_mm + cy: the same a and b as the perspective camera's
// direction, since both are the screen's offset at unit scale. The rays start in the camera's
// plane z_C = 0 (nothing below it is seen directly) and run along +z_C.
std::string CameraText(const RigParams& rig, double a, double b, double right_x, double up_x,
                       double up_y) {
  std::ostringstream s;
  if (rig.lens == LensKind::kTelecentric) {
    s << "camera { orthographic location " << Vec(a, b, 0) << "\n"
      << "  direction <0, 0, 1>\n";
  } else {
    s << "camera { perspective location <0, 0, 0>\n"
      << "  direction " << Vec(a, b, 1) << "\n";
  }
  s << "  right " << Vec(right_x, 0, 0) << "\n"
    << "  up " << Vec(up_x, up_y, 0) << " }\n";
  return s.str();
}

}  // namespace

std::string PovSceneText(const RigParams& rig, const SceneContent& content) {
  const double fx = rig.camera[kFx], fy = rig.camera[kFy], cx = rig.camera[kCx], cy = rig.camera[kCy],
               skew = rig.camera[kSkew];
  const double W = rig.image_width, H = rig.image_height;
  // Camera vectors (see the header): right = W/fx, up = (s H/(fx fy), H/fy), direction (a, b, 1).
  const double up_x = skew * H / (fx * fy), up_y = H / fy, right_x = W / fx;
  const double b = (cy + 0.5 - H / 2) / fy;
  const double a = -cx / fx + skew * cy / (fx * fy) - (0.5 - W / 2) / fx - up_x * (0.5 - 0.5 / H);

  std::ostringstream s;
  s << "// omnistereo: rig scene in the camera frame C mapped to POV-Ray by (x, -y, z).\n"
    << "#version 3.7;\n"
    << "global_settings { assumed_gamma 1.0 max_trace_level 12 }\n"
    << "background { rgb 0 }\n"
    << "#declare MirrorFinish = texture { pigment { rgb 0 } finish { reflection { 1.0 } "
       "ambient 0 diffuse 0 emission 0 } }\n"
    << "#declare MatteBlack = texture { pigment { rgb 0.02 } finish { ambient 0 diffuse 0 "
       "emission 1 } }\n"
    << "#declare SelfLit = finish { ambient 0 diffuse 0 emission 1 }\n"
    << "#declare LipPaint = finish { ambient " << Num(kLipAmbient) << " diffuse 1 emission 0 }\n"
    << (rig.Single() ? "#declare Housing = texture { pigment { rgb 0.04 } finish { ambient 0 "
                       "diffuse 0 emission 1 } }\n"
                     : "")
    << (content.draw_mirrors && rig.profile1.present
            ? ProfileFunctions(
                  rig.Single() ? SingleConicSag(SingleConic(rig))
                               : HyperboloidConicZ(HyperboloidSheet<double>::Mirror1(
                                     rig.mirror1_shape[kShapeC], rig.mirror1_shape[kShapeK])),
                  rig.profile1, rig.mirror1_profile.data(), 1)
            : "")
    << (content.draw_mirrors && !rig.Single() && rig.profile2.present
            ? ProfileFunctions(HyperboloidConicZ(HyperboloidSheet<double>::Mirror2(
                                   rig.mirror2_shape[kShapeC], rig.mirror2_shape[kShapeK], rig.d)),
                               rig.profile2, rig.mirror2_profile.data(), 2)
            : "")
    << CameraText(rig, a, b, right_x, up_x, up_y)
    << (content.draw_mirrors ? RoomLamps(rig, content) : "")
    << "union {  // everything below is in C\n";

  if (content.draw_mirrors) s << (rig.Single() ? SingleMirrorBody(rig, content.post_grey) : MirrorBodies(rig, content.post_grey));

  for (const Marker& m : content.markers) {
    s << "  sphere { " << Vec(m.center_in_cam.x(), m.center_in_cam.y(), m.center_in_cam.z())
      << ", " << Num(m.radius_mm) << " pigment { rgb 1 } finish { SelfLit } no_shadow }\n";
  }

  for (const TargetSheet& sheet : content.targets) s << TargetObject(sheet);

  s << RoomObject(content);

  s << "  scale <1, -1, 1>  // C -> POV-Ray\n}\n";
  return s.str();
}

bool RenderScene(const std::string& pov_text, const std::string& out_png,
                 const RenderOptions& options, std::string* error) {
  std::string pov_path = out_png;
  const auto dot = pov_path.rfind('.');
  pov_path = (dot == std::string::npos ? pov_path : pov_path.substr(0, dot)) + ".pov";
  {
    std::ofstream f(pov_path);
    f << pov_text;
    if (!f) {
      *error = "cannot write " + pov_path;
      return false;
    }
  }
  // POV-Ray's default I/O security only lets it read and write below its working directory (and
  // /tmp, $HOME), so it runs in the output folder with bare file names.
  const auto slash = out_png.rfind('/');
  const std::string folder = slash == std::string::npos ? "." : out_png.substr(0, slash);
  const auto base = [](const std::string& path) {
    const auto k = path.rfind('/');
    return k == std::string::npos ? path : path.substr(k + 1);
  };
  std::ostringstream cmd;
  cmd << "cd '" << folder << "' && povray -D +I'" << base(pov_path) << "' +O'" << base(out_png)
      << "' +FN" << (options.bits == 16 ? 16 : 8) << " File_Gamma=1.0 +W" << options.width
      << " +H" << options.height;
  if (options.antialias) cmd << " +A0.0 +AM2 +R" << options.antialias_depth;
  else cmd << " -A";
  if (options.col1 > options.col0 && options.row1 > options.row0) {
    // POV-Ray's window is 1-based and inclusive.
    cmd << " +SC" << options.col0 + 1 << " +EC" << options.col1 << " +SR" << options.row0 + 1
        << " +ER" << options.row1;
  }
  if (options.threads > 0) cmd << " +WT" << options.threads;
  const std::string log_path = pov_path + ".log";
  cmd << " > '" << base(log_path) << "' 2>&1";  // relative to the folder it runs in
  const int status = std::system(cmd.str().c_str());
  if (status != 0) {
    std::ifstream log(log_path);
    std::string line, tail;
    while (std::getline(log, line)) tail = line.empty() ? tail : line;
    *error = "povray failed (exit " + std::to_string(WEXITSTATUS(status)) + "): " + tail;
    return false;
  }
  std::remove(log_path.c_str());
  return true;
}

}  // namespace omni::synthetic
