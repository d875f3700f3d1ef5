// The certified step of conservative advancement for one pair of posed convex cores moving with
// constant twists: how long their gap stays above a target, from the separation along one
// direction found now (fixed in the world, or turning with either body). It does not find
// that direction (convex_distance.h) nor traverse meshes (mesh_queries.h). Internal to the
// library (not installed).
#pragma once

#include "posed_convex.h"

#include <Eigen/Core>

namespace vadop {
namespace detail {

// The constant twist a step assumes for a body: the velocities of its rotation centre.
struct Kin {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();  // linear velocity of the body origin
  Eigen::Vector3d w = Eigen::Vector3d::Zero();  // angular velocity (fixed frame)
};

// Largest step in [0, horizon] such that the gap of A and B stays > adv, certified by the
// separation along a direction n (unit, a to b) found at the current time; `clear` when
// that holds over the whole horizon. Three certificates, the best step wins (each is a
// lower bound of the gap for all later times, so any of them is safe):
//
// (1) n fixed in the world frame:
//     s(t+D) >= n.(P + D V) - hA(n - D wa x n) - hB(-n + D wb x n)
//                - D^2/2 (ra |wa| |wa x n| + rb |wb| |wb x n|)
//     with P = pb - pa, V = vb - va, hX the support of the padded shape about its origin at
//     time t. Rotating n by -w D differs from its first-order term by at most
//     |w| |w x n| D^2 / 2 and support functions are Lipschitz in the direction with the
//     lever arm r. Exact for translation. Also s(t+D) >= s(t) - D (-n.V + ra|wa x n| + rb|wb x n|).
// (2) n attached to b (it turns with b, like a face normal of b, so b's support along it is
//     constant): with E = exp([w] D), u = Ea^T Eb n (|u - n - D (wb - wa) x n| <=
//     (|wa| + |wb|)^2 D^2 / 2) and Eb n = n + D wb x n + e (|e| <= |wb| |wb x n| D^2 / 2):
//     s(t+D) >= n.P + D ((wb x n).P + n.V) + D^2 min(0, (wb x n).V)
//                - |wb| |wb x n| D^2 (|P| + D |V|) / 2 - hB(-n)
//                - hA(n + D (wb - wa) x n) - ra (|wa| + |wb|)^2 D^2 / 2.
//     This follows a rotating face closely: its first-order term is the true rate.
// (3) n attached to a: the same with the roles of a and b exchanged.
// All three are concave in D.
// `deviation`: for bodies whose motion only stays near the constant twist (v, w) of their
// Kin -- every point within deviation_x D^2 / 2 of where the twist takes it, deviation the sum
// over both bodies -- each bound less deviation D^2 / 2 bounds the true gap (a support
// function moves by at most the largest displacement of a point), still concave.
// `cap`: the caller only needs to know the step up to cap (a mesh's best step so far);
// the refinements stop as soon as a certificate reaches it.
double separationStep(const Convex& A, const Kin& ka, const Convex& B, const Kin& kb,
                      const Eigen::Vector3d& n, double horizon, double adv, double cap, bool* clear,
                      double deviation = 0.0);

}  // namespace detail
}  // namespace vadop
