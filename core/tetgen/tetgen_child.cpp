// SPDX-License-Identifier: AGPL-3.0-or-later
// pdrmesh-tetgen: the helper process in which the TetGen adapter runs TetGen
// (tetgen_adapter.cpp starts it with posix_spawn). TetGen can crash, hang, call
// exit() or throw on bad input; here it takes down only this process, which
// the adapter supervises with a time limit. The request comes on stdin and the
// answer goes to descriptor 3 (format: tetgen_wire.hpp); the parent validates
// everything it receives. This is the only file of the project that includes
// <tetgen.h>.
//
// Starting a fresh program (rather than running TetGen in a bare fork of the
// caller) means the child inherits none of the parent's threads' locks: the
// parent may be a coordinator with gRPC threads, or built with a sanitizer
// whose allocator is not fork-safe.

#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <new>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "tetgen_wire.hpp"

#ifndef TETLIBRARY
#define TETLIBRARY
#endif
#include <tetgen.h>

namespace {

namespace wire = pdrmesh::tetgen_wire;

bool send_error(wire::Answer answer, int code, std::string_view message) {
  wire::AnswerHeader h;
  h.answer = static_cast<std::uint32_t>(answer);
  h.code = code;
  h.message_len = message.size();
  return wire::write_all(wire::kAnswerFd, &h, sizeof h) &&
         wire::write_all(wire::kAnswerFd, message.data(), message.size());
}

/// TetGen's input, pointing into arrays TetGen must not free (tetgenio's
/// destructor would delete[] them while an exception unwinds).
struct BorrowedInput : tetgenio {
  BorrowedInput() = default;
  BorrowedInput(const BorrowedInput&) = delete;
  BorrowedInput& operator=(const BorrowedInput&) = delete;
  ~BorrowedInput() {
    pointlist = nullptr;
    facetlist = nullptr;
    numberoffacets = 0;
  }
};

/// The request after its header, read into the arrays TetGen's input points into.
struct Request {
  std::vector<double> points;  // 3 per point
  std::vector<int> corners;    // 3 per triangle
  std::vector<tetgenio::polygon> polygons;
  std::vector<tetgenio::facet> facets;
  std::vector<char> switches;  // NUL-terminated, writable (TetGen's API takes char*)
};

/// Reads the request body; throws std::runtime_error on a short or malformed one.
Request read_request(const wire::RequestHeader& h) {
  constexpr std::uint64_t kMaxItems = 1ull << 31;  // TetGen's indices are int
  if (h.n_points >= kMaxItems || h.n_triangles >= kMaxItems || h.switches_len > 4096)
    throw std::runtime_error("pdrmesh-tetgen: malformed request header");
  Request r;
  r.points.resize(3 * h.n_points);
  r.corners.resize(3 * h.n_triangles);
  r.switches.resize(h.switches_len + 1, '\0');
  if (!wire::read_all(0, r.points.data(), r.points.size() * sizeof(double)) ||
      !wire::read_all(0, r.corners.data(), r.corners.size() * sizeof(int)) ||
      !wire::read_all(0, r.switches.data(), h.switches_len))
    throw std::runtime_error("pdrmesh-tetgen: the request ended early");
  r.polygons.resize(h.n_triangles);
  r.facets.resize(h.n_triangles);
  for (std::size_t i = 0; i < h.n_triangles; ++i) {
    r.polygons[i].vertexlist = r.corners.data() + 3 * i;
    r.polygons[i].numberofvertices = 3;
    r.facets[i].polygonlist = &r.polygons[i];
    r.facets[i].numberofpolygons = 1;
    r.facets[i].holelist = nullptr;
    r.facets[i].numberofholes = 0;
  }
  return r;
}

/// Runs the injected fault, if any (a test seam: see TetgenOptions::Fault).
void inject(wire::Fault fault) {
  switch (fault) {
    case wire::Fault::kNone: return;
    case wire::Fault::kCrash:
      std::printf("injected fault: crashing\n");
      ::raise(SIGSEGV);
      return;
    case wire::Fault::kHang:
      std::printf("injected fault: hanging\n");
      for (;;) ::pause();
    case wire::Fault::kExit:
      std::printf("injected fault: calling exit(3)\n");
      std::exit(3);
    case wire::Fault::kThrow: throw std::runtime_error("injected fault: exception thrown by the mesher");
  }
  throw std::runtime_error("pdrmesh-tetgen: unknown fault in the request");
}

/// Meshes the request and writes the answer; returns whether it was sent.
bool mesh(const wire::RequestHeader& h) {
  Request request = read_request(h);
  BorrowedInput in;
  in.firstnumber = 0;
  in.numberofpoints = static_cast<int>(h.n_points);
  in.pointlist = request.points.data();
  in.numberoffacets = static_cast<int>(h.n_triangles);
  in.facetlist = request.facets.data();
  tetgenio out;
  ::tetrahedralize(request.switches.data(), &in, &out);
  if (out.numberofcorners != 4 || out.numberofpoints < 0 || out.numberoftetrahedra < 0)
    throw std::runtime_error("unexpected TetGen output (" + std::to_string(out.numberofcorners) + " corners, " +
                             std::to_string(out.numberofpoints) + " points, " +
                             std::to_string(out.numberoftetrahedra) + " tets)");
  wire::AnswerHeader a;
  a.answer = static_cast<std::uint32_t>(wire::Answer::kOk);
  a.n_points = static_cast<std::uint64_t>(out.numberofpoints);
  a.n_tets = static_cast<std::uint64_t>(out.numberoftetrahedra);
  return wire::write_all(wire::kAnswerFd, &a, sizeof a) &&
         wire::write_all(wire::kAnswerFd, out.pointlist, a.n_points * 3 * sizeof(double)) &&
         wire::write_all(wire::kAnswerFd, out.tetrahedronlist, a.n_tets * 4 * sizeof(int));
}

}  // namespace

int main() {
  wire::RequestHeader h;
  if (::isatty(0) || !wire::read_all(0, &h, sizeof h) || h.magic != wire::kRequestMagic) {
    std::fprintf(stderr,
                 "pdrmesh-tetgen is a helper of pdrmesh: it runs TetGen for a request that pdrmesh writes on its "
                 "standard input; it is not meant to be run by hand.\n");
    return 2;
  }
  // A crash of TetGen must end this process by its signal, which the parent
  // reports (and reads as bad input after TetGen's "intersect" diagnostics):
  // no handler of a sanitizer's runtime may turn it into an exit status.
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) ::signal(sig, SIG_DFL);
  struct rlimit no_core = {0, 0};
  ::setrlimit(RLIMIT_CORE, &no_core);
  if (h.memory_limit > 0) {
    // Set here, after start-up (a sanitizer's runtime maps its shadow memory first).
    struct rlimit as = {h.memory_limit, h.memory_limit};
    ::setrlimit(RLIMIT_AS, &as);
  }
  // No buffering, so that what TetGen printed before a crash reaches the log.
  std::setvbuf(stdout, nullptr, _IONBF, 0);
  bool sent = false;
  try {
    inject(static_cast<wire::Fault>(h.fault));
    sent = mesh(h);
  } catch (int code) {
    sent = send_error(wire::Answer::kTetgenCode, code, {});
  } catch (const std::bad_alloc&) {
    sent = send_error(wire::Answer::kOutOfMemory, 0, {});
  } catch (const std::exception& e) {
    sent = send_error(wire::Answer::kException, 0, e.what());
  } catch (...) {
    sent = send_error(wire::Answer::kUnknown, 0, {});
  }
  // TetGen's output and input arrays: the process ends here, skip every
  // destructor and atexit handler (and a leak checker's report of them).
  ::_exit(sent ? 0 : 122);
}
