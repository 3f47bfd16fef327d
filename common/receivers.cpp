#include "common/receivers.h"

#include <cmath>
#include <glm/geometric.hpp>

namespace penumbra {

void plane_axes(const glm::dvec3& normal, glm::dvec3& u, glm::dvec3& v) {
    const glm::dvec3 n = glm::normalize(normal);
    glm::dvec3 axis(1, 0, 0);
    if (std::abs(n.y) < std::abs(n.x) && std::abs(n.y) <= std::abs(n.z))
        axis = {0, 1, 0};
    else if (std::abs(n.z) < std::abs(n.x) && std::abs(n.z) < std::abs(n.y))
        axis = {0, 0, 1};
    u = glm::normalize(axis - glm::dot(axis, n) * n);
    v = glm::cross(n, u);
}

namespace {

void add_quad(Scene& scene, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d,
              bool double_sided) {
    for (std::uint32_t t : {scene.add_triangle(a, b, c, double_sided), scene.add_triangle(a, c, d, double_sided)})
        scene.triangle_node[t] = kReceiverNode;
}

}  // namespace

void add_receiver(Scene& scene, const Receiver& r) {
    if (r.type == ReceiverType::plane) {
        glm::dvec3 u, v;
        plane_axes(r.normal, u, v);
        const glm::dvec3 hu = u * (0.5 * r.size.x), hv = v * (0.5 * r.size.y);
        const glm::dvec3& c = r.center;
        add_quad(scene, c - hu - hv, c + hu - hv, c + hu + hv, c - hu + hv, true);  // counter-clockwise about normal
        return;
    }
    const glm::dvec3 lo = r.center - 0.5 * r.size, hi = r.center + 0.5 * r.size;
    auto p = [&](int x, int y, int z) { return glm::dvec3(x ? hi.x : lo.x, y ? hi.y : lo.y, z ? hi.z : lo.z); };
    // Each face counter-clockwise seen from outside.
    add_quad(scene, p(1, 0, 0), p(1, 1, 0), p(1, 1, 1), p(1, 0, 1), false);  // +x
    add_quad(scene, p(0, 0, 0), p(0, 0, 1), p(0, 1, 1), p(0, 1, 0), false);  // -x
    add_quad(scene, p(0, 1, 0), p(0, 1, 1), p(1, 1, 1), p(1, 1, 0), false);  // +y
    add_quad(scene, p(0, 0, 0), p(1, 0, 0), p(1, 0, 1), p(0, 0, 1), false);  // -y
    add_quad(scene, p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1), false);  // +z
    add_quad(scene, p(0, 0, 0), p(0, 1, 0), p(1, 1, 0), p(1, 0, 0), false);  // -z
}

}  // namespace penumbra
