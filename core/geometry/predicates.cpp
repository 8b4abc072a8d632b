// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/predicates.hpp"

#include <cmath>

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

// The first stage of Shewchuk's orient3d and insphere (the same operations and
// error bounds as his code, with epsilon = 2^-53 as exactinit computes it),
// inline: when the rounded determinant clears the bound its sign is the exact
// one, so libtet's call (the same stage again, then the adaptive stages) is
// needed only when it does not.
constexpr double kEpsilon = 0x1p-53;
constexpr double kO3dErrBoundA = (7.0 + 56.0 * kEpsilon) * kEpsilon;
constexpr double kIspErrBoundA = (16.0 + 224.0 * kEpsilon) * kEpsilon;

/// Sign of Shewchuk's orient3d(a, b, c, d) when the filter decides it, else 2.
int filtered_orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const double adx = a[0] - d[0], bdx = b[0] - d[0], cdx = c[0] - d[0];
  const double ady = a[1] - d[1], bdy = b[1] - d[1], cdy = c[1] - d[1];
  const double adz = a[2] - d[2], bdz = b[2] - d[2], cdz = c[2] - d[2];
  const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
  const double cdxady = cdx * ady, adxcdy = adx * cdy;
  const double adxbdy = adx * bdy, bdxady = bdx * ady;
  const double det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
  const double permanent = (std::fabs(bdxcdy) + std::fabs(cdxbdy)) * std::fabs(adz) +
                           (std::fabs(cdxady) + std::fabs(adxcdy)) * std::fabs(bdz) +
                           (std::fabs(adxbdy) + std::fabs(bdxady)) * std::fabs(cdz);
  const double errbound = kO3dErrBoundA * permanent;
  if (det > errbound) return 1;
  if (-det > errbound) return -1;
  return 2;
}

/// Sign of Shewchuk's insphere(a, b, c, d, e) when the filter decides it, else 2.
int filtered_insphere(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, const Vec3& e) {
  const double aex = a[0] - e[0], bex = b[0] - e[0], cex = c[0] - e[0], dex = d[0] - e[0];
  const double aey = a[1] - e[1], bey = b[1] - e[1], cey = c[1] - e[1], dey = d[1] - e[1];
  const double aez = a[2] - e[2], bez = b[2] - e[2], cez = c[2] - e[2], dez = d[2] - e[2];
  const double aexbey = aex * bey, bexaey = bex * aey, ab = aexbey - bexaey;
  const double bexcey = bex * cey, cexbey = cex * bey, bc = bexcey - cexbey;
  const double cexdey = cex * dey, dexcey = dex * cey, cd = cexdey - dexcey;
  const double dexaey = dex * aey, aexdey = aex * dey, da = dexaey - aexdey;
  const double aexcey = aex * cey, cexaey = cex * aey, ac = aexcey - cexaey;
  const double bexdey = bex * dey, dexbey = dex * bey, bd = bexdey - dexbey;
  const double abc = aez * bc - bez * ac + cez * ab;
  const double bcd = bez * cd - cez * bd + dez * bc;
  const double cda = cez * da + dez * ac + aez * cd;
  const double dab = dez * ab + aez * bd + bez * da;
  const double alift = aex * aex + aey * aey + aez * aez;
  const double blift = bex * bex + bey * bey + bez * bez;
  const double clift = cex * cex + cey * cey + cez * cez;
  const double dlift = dex * dex + dey * dey + dez * dez;
  const double det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd);
  const double aezp = std::fabs(aez), bezp = std::fabs(bez), cezp = std::fabs(cez), dezp = std::fabs(dez);
  const double aexbeyp = std::fabs(aexbey), bexaeyp = std::fabs(bexaey);
  const double bexceyp = std::fabs(bexcey), cexbeyp = std::fabs(cexbey);
  const double cexdeyp = std::fabs(cexdey), dexceyp = std::fabs(dexcey);
  const double dexaeyp = std::fabs(dexaey), aexdeyp = std::fabs(aexdey);
  const double aexceyp = std::fabs(aexcey), cexaeyp = std::fabs(cexaey);
  const double bexdeyp = std::fabs(bexdey), dexbeyp = std::fabs(dexbey);
  const double permanent =
      ((cexdeyp + dexceyp) * bezp + (dexbeyp + bexdeyp) * cezp + (bexceyp + cexbeyp) * dezp) * alift +
      ((dexaeyp + aexdeyp) * cezp + (aexceyp + cexaeyp) * dezp + (cexdeyp + dexceyp) * aezp) * blift +
      ((aexbeyp + bexaeyp) * dezp + (bexdeyp + dexbeyp) * aezp + (dexaeyp + aexdeyp) * bezp) * clift +
      ((bexceyp + cexbeyp) * aezp + (cexaeyp + aexceyp) * bezp + (aexbeyp + bexaeyp) * cezp) * dlift;
  const double errbound = kIspErrBoundA * permanent;
  if (det > errbound) return 1;
  if (-det > errbound) return -1;
  return 2;
}

}  // namespace

int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  if (const int s = filtered_orient3d(a, b, c, d); s != 2) return -s;
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
  if (const int s = filtered_insphere(a, b, c, d, e); s != 2) return -s;
  Vec3 pa = a, pb = b, pc = c, pd = d, pe = e;
  // Shewchuk's insphere is positive for "inside" when (a,b,c,d) is positive in
  // his orient3d sense, which is negative in ours: flip.
  return -sign(::insphere(pa.data(), pb.data(), pc.data(), pd.data(), pe.data()));
}

bool collinear(const Vec3& a, const Vec3& b, const Vec3& c) {
  return orient2d(a, b, c, 0) == 0 && orient2d(a, b, c, 1) == 0 && orient2d(a, b, c, 2) == 0;
}

}  // namespace pdrmesh::exact
