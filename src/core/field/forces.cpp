// The field's laws out of line (forces.hpp, namespace out_of_line): pfield.field.forces calls these, so a law
// evaluated from Python rounds as in the core's loops (this file has the core's flags: no fused multiply-adds).
#include "field/forces.hpp"

namespace pfield::field::out_of_line {

Vec3 attraction(const Vec3& e, double gain, double threshold) { return field::attraction(e, gain, threshold); }

double khatib_magnitude(double distance, double gain, double influence, double cap) {
  return field::khatib_magnitude(distance, gain, influence, cap);
}

Vec3 soft_saturate(const Vec3& v, double limit) { return field::soft_saturate(v, limit); }

double damper_speed(double distance, double influence, double safety, double gain, double max_speed,
                    double max_acceleration) {
  return field::damper_speed(distance, influence, safety, gain, max_speed, max_acceleration);
}

double stepped_damper_speed(double distance, double influence, double safety, double max_speed, double dt) {
  return field::stepped_damper_speed(distance, influence, safety, max_speed, dt);
}

Limited deflect(const Vec3& v, const Vec3& n, const Vec3& c, double allowed, double circulation) {
  return field::deflect(v, n, c, allowed, circulation);
}

Limited project_damper(const Vec3& v, const Vec3& n, double allowed) { return field::project_damper(v, n, allowed); }

}  // namespace pfield::field::out_of_line
