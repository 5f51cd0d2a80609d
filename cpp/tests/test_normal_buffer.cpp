// The buffered normal stream (raydamp/random/philox.hpp computes kBuffered Philox blocks ahead) against
// the one-block-at-a-time stream it replaced (reference_normal_stream.hpp): the same numbers bit for bit
// and the same State after every call, for fill() of any length, next(), their mixture, slow-path draws
// (the ziggurat's wedges and tail take further blocks: counted here), a restore() of a saved State in the
// middle (forward, backward, and into the buffered range), copies, the counter's wrap at 2^64, and the
// noise of a whole Workspace as the step loop draws it. Built once per way of computing the blocks
// (RAYDAMP_NORMAL_SIMD: AVX2 where the processor has it, SSE2, portable; cpp/tests/CMakeLists.txt).
#include <Eigen/Dense>
#include <cstdint>
#include <vector>

#include "check.hpp"
#include "raydamp/raydamp.hpp"
#include "reference_normal_stream.hpp"

using namespace raydamp;

namespace {

bool same(const NormalStream::State& a, const NormalStream::State& b) {
  return a.block == b.block && a.spare == b.spare && (!a.spare || a.value == b.value);
}

// n numbers from the reference, one next() at a time.
std::vector<double> reference(ReferenceNormalStream& r, long n) {
  std::vector<double> out(static_cast<std::size_t>(n));
  for (double& v : out) v = r.next();
  return out;
}

}  // namespace

int main() {
  // 10^6 normals by fill() in pieces of every awkward length (odd, one, a buffer's worth and more, with
  // the spare left over or not), interleaved with next(), for seeds using the key's both halves and
  // streams using the counter's both halves: every number equal, and the state after each call.
  const long N = 1000000;
  const std::uint64_t seeds[] = {0, 12345, 0xfedcba9876543210ull}, streams[] = {0, 7, 0x0000000100000003ull};
  const long pieces[] = {1, 2, 3, 5, 16, 17, 31, 32, 33, 64, 1000, 4097};
  for (const std::uint64_t seed : seeds) {
    for (const std::uint64_t stream : streams) {
      NormalStream s(seed, stream);
      ReferenceNormalStream r(seed, stream);
      long drawn = 0, unequal = 0, states = 0, k = 0;
      Eigen::VectorXd v;
      while (drawn < N) {
        const long n = pieces[k++ % 12];
        v.resize(n);
        s.fill(v);
        const std::vector<double> expected = reference(r, n);
        for (long i = 0; i < n; ++i) unequal += v[i] != expected[static_cast<std::size_t>(i)];
        if (k % 3 == 0) {
          unequal += s.next() != r.next();
          ++drawn;
        }
        states += !same(s.state(), r.state());
        drawn += n;
      }
      CHECK(unequal == 0);
      CHECK(states == 0);
      // Slow-path draws happened and were matched: a block gives two fast normals, so the blocks beyond
      // drawn / 2 are the wedges' and the tail's (about 1.4% of draws take one: > 5000 of 10^6).
      CHECK(r.state().block > std::uint64_t(drawn / 2 + 5000));
    }
  }

  // A restore() of a saved State in the middle, as the step loop replays a block of steps: save at
  // 500 001 draws (a spare pending), draw 10^5 more, restore, and the replay is the same 10^5 numbers;
  // then restore states from before the buffered range, inside it and ahead of it.
  {
    NormalStream s(2026, 11);
    ReferenceNormalStream r(2026, 11);
    Eigen::VectorXd v(500001), w(100000), replay(100000);
    s.fill(v);
    reference(r, 500001);
    const NormalStream::State saved = s.state();
    CHECK(saved.spare && same(saved, r.state()));
    s.fill(w);
    const std::vector<double> expected = reference(r, 100000);
    long unequal = 0;
    for (int i = 0; i < 100000; ++i) unequal += w[i] != expected[static_cast<std::size_t>(i)];
    s.restore(saved);
    s.fill(replay);
    CHECK(replay == w);
    CHECK(unequal == 0);
    CHECK(same(s.state(), r.state()));
    // backward into a block just consumed (inside the buffer), and a state far ahead, each against the
    // reference restored to the same state
    for (const std::uint64_t back : {1ull, 3ull, 40ull, 1000000ull}) {
      NormalStream::State st = s.state();
      st.block = st.block > back ? st.block - back : st.block + back;
      st.spare = false;
      s.restore(st);
      ReferenceNormalStream q(2026, 11);
      q.restore(st);
      long diff = 0;
      for (int i = 0; i < 1000; ++i) diff += s.next() != q.next();
      CHECK(diff == 0);
      CHECK(same(s.state(), q.state()));
    }
  }

  // A copy taken mid-buffer continues as the original does (Workspace copies its streams).
  {
    NormalStream s(5, 9);
    for (int i = 0; i < 37; ++i) s.next();
    NormalStream copy = s;
    long diff = 0;
    for (int i = 0; i < 10000; ++i) diff += copy.next() != s.next();
    CHECK(diff == 0);
  }

  // The block counter wraps at 2^64 as the reference's does: the buffer starting 5 blocks before the wrap
  // holds blocks 2^64 - 5 .. 10 (its unsigned range test must not take block 0 for an outside one).
  {
    NormalStream s(77, 1);
    ReferenceNormalStream r(77, 1);
    const NormalStream::State near_end{~std::uint64_t(0) - 4, false, 0.0};
    s.restore(near_end);
    r.restore(near_end);
    Eigen::VectorXd v(200);
    s.fill(v);
    const std::vector<double> expected = reference(r, 200);
    long diff = 0;
    for (int i = 0; i < 200; ++i) diff += v[i] != expected[static_cast<std::size_t>(i)];
    CHECK(diff == 0);
    CHECK(same(s.state(), r.state()));
    CHECK(s.state().block < 1000);  // wrapped
  }

  // The step loop's draw: Workspace::draw_noise() fills xi from one stream (7 coordinates: the spare
  // carries over between steps) or calls each lane's next() (3 lanes, streams 4, 5, 6).
  {
    Workspace<Eigen::Dynamic> one(7, 1), lanes(3, 1);
    one.noise = NormalStream(3, 4);
    for (int i = 0; i < 3; ++i) lanes.lane_noise.emplace_back(3, 4 + i);
    ReferenceNormalStream r(3, 4), lane[3] = {{3, 4}, {3, 5}, {3, 6}};
    long diff = 0;
    for (int step = 0; step < 5000; ++step) {
      one.draw_noise();
      for (int i = 0; i < 7; ++i) diff += one.xi[i] != r.next();
      lanes.draw_noise();
      for (int i = 0; i < 3; ++i) diff += lanes.xi[i] != lane[i].next();
    }
    CHECK(diff == 0);
  }

  if (test::failures) std::printf("%d check(s) failed\n", test::failures);
  return test::failures ? 1 : 0;
}
