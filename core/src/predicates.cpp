// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/predicates.hpp"

// Shewchuk's predicates as compiled into libtet (C++ linkage, global namespace).
// Declared here rather than through <tetgen.h>: tetgen_adapter.cpp is the only
// file that includes that header.
void exactinit(int verbose, int noexact, int nofilter, double maxx, double maxy, double maxz);
double orient3d(double* pa, double* pb, double* pc, double* pd);
double orient2d(double* pa, double* pb, double* pc);
double insphere(double* pa, double* pb, double* pc, double* pd, double* pe);

namespace pdrmesh::exact {
namespace {

// Runs exactinit once, when the library is loaded: verbose off, exact
// arithmetic on, TetGen's static (bounding-box) filter off. The box arguments
// only feed that filter and are unused with it off.
struct Init {
  Init() { ::exactinit(0, 0, 1, 1.0, 1.0, 1.0); }
};
const Init kInit;

int sign(double v) { return (v > 0.0) - (v < 0.0); }

}  // namespace

int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  Vec3 pa = a, pb = b, pc = c, pd = d;
  // Shewchuk: positive when d is below abc seen with abc counterclockwise,
  // i.e. the opposite of our signed volume.
  return -sign(::orient3d(pa.data(), pb.data(), pc.data(), pd.data()));
}

int orient2d(const Vec3& a, const Vec3& b, const Vec3& c, int drop) {
  const int u = (drop + 1) % 3;
  const int v = (drop + 2) % 3;
  double pa[2] = {a[u], a[v]}, pb[2] = {b[u], b[v]}, pc[2] = {c[u], c[v]};
  return sign(::orient2d(pa, pb, pc));
}

int insphere(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, const Vec3& e) {
  Vec3 pa = a, pb = b, pc = c, pd = d, pe = e;
  // Shewchuk's insphere is positive for "inside" when (a,b,c,d) is positive in
  // his orient3d sense, which is negative in ours: flip.
  return -sign(::insphere(pa.data(), pb.data(), pc.data(), pd.data(), pe.data()));
}

bool collinear(const Vec3& a, const Vec3& b, const Vec3& c) {
  return orient2d(a, b, c, 0) == 0 && orient2d(a, b, c, 1) == 0 && orient2d(a, b, c, 2) == 0;
}

}  // namespace pdrmesh::exact
