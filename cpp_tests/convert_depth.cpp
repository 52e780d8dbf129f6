// convert_depth: the whole-image pass refl_image_convert_depth, split into row
// bands (refl_image_row_band) across threads, against one call over all rows and
// against the per-texel functions, for every pair of depth conventions,
// finite and infinite far planes, padded strides and in-place conversion.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <thread>
#include <vector>

#include "check.hpp"
#include "refl.h"

namespace {

constexpr uint32_t kW = 333, kH = 217, kSrcStride = 340, kDstStride = 335, kThreads = 4;

uint32_t lcg(uint32_t& s) {
    s = s * 1664525u + 1013904223u;
    return s >> 8;
}

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void run(const refl_camera& cam, const char* name) {
    // Linear depths spread over [near, min(far, 1000)] (log-uniform).
    std::vector<float> linear(size_t(kSrcStride) * kH, -1.0f);
    uint32_t seed = 12345u;
    const double zmax = std::isinf(cam.z_far) ? 1000.0 : double(cam.z_far);
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            const double u = double(lcg(seed) & 0xFFFFu) / 65535.0;
            linear[size_t(y) * kSrcStride + x] = float(cam.z_near * std::pow(zmax / cam.z_near, u));
        }

    double worst_round_trip = 0.0;
    long pairs = 0;
    for (uint32_t from = 0; from < 3; ++from) {
        // The source in convention `from`.
        std::vector<float> src(linear.size(), -2.0f);
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x) {
                const size_t i = size_t(y) * kSrcStride + x;
                CHECK_STATUS(refl_camera_encode_depth(&src[i], &cam, linear[i], from), REFL_STATUS_OK);
            }
        const refl_image_f32 src_img{src.data(), src.size(), kW, kH, kSrcStride};
        for (uint32_t to = 0; to < 3; ++to) {
            ++pairs;
            const size_t dst_len = size_t(kH - 1) * kDstStride + kW;
            std::vector<float> one(dst_len + 8, 7.0f), banded(dst_len + 8, 7.0f);
            // One call over all rows.
            CHECK_STATUS(refl_image_convert_depth(refl_image_f32_mut{one.data(), dst_len, kW, kH, kDstStride}, src_img,
                                            &cam, from, to, refl_row_range{0, kH}),
                         REFL_STATUS_OK);
            // kThreads bands on kThreads threads.
            std::vector<std::thread> threads;
            std::vector<uint32_t> status(kThreads, 99u);
            for (uint32_t t = 0; t < kThreads; ++t) {
                threads.emplace_back([&, t] {
                    refl_row_range band;
                    if (refl_image_row_band(&band, kH, t, kThreads) != REFL_STATUS_OK) return;
                    status[t] = refl_image_convert_depth(refl_image_f32_mut{banded.data(), dst_len, kW, kH, kDstStride},
                                                   src_img, &cam, from, to, refl_row_range{band.begin, band.end});
                });
            }
            for (auto& th : threads) th.join();
            for (uint32_t s : status) CHECK_EQ(s, uint32_t(REFL_STATUS_OK));
            CHECK(std::memcmp(one.data(), banded.data(), one.size() * sizeof(float)) == 0);

            // Texel by texel: the per-texel functions give the same bits;
            // padding and the tail stay untouched; the round trip is close.
            for (uint32_t y = 0; y < kH; ++y) {
                for (uint32_t x = 0; x < kDstStride && size_t(y) * kDstStride + x < one.size(); ++x) {
                    const size_t i = size_t(y) * kDstStride + x;
                    if (x >= kW) {
                        CHECK(one[i] == 7.0f);
                        continue;
                    }
                    const size_t j = size_t(y) * kSrcStride + x;
                    float z = 0.0f, want = 0.0f, back = 0.0f;
                    CHECK_STATUS(refl_camera_decode_depth(&z, &cam, src[j], from), REFL_STATUS_OK);
                    CHECK_STATUS(refl_camera_encode_depth(&want, &cam, z, to), REFL_STATUS_OK);
                    CHECK(same_bits(one[i], want));
                    CHECK_STATUS(refl_camera_decode_depth(&back, &cam, one[i], to), REFL_STATUS_OK);
                    const double rel = std::fabs(double(back) - linear[j]) / linear[j];
                    worst_round_trip = std::max(worst_round_trip, rel);
                }
            }
            CHECK(one[dst_len] == 7.0f);
        }
    }
    // In place: LINEAR -> ZERO_TO_ONE -> REVERSED_Z -> LINEAR on one buffer.
    std::vector<float> buf = linear;
    const refl_image_f32_mut m{buf.data(), buf.size(), kW, kH, kSrcStride};
    const refl_image_f32 c{buf.data(), buf.size(), kW, kH, kSrcStride};
    CHECK_STATUS(refl_image_convert_depth(m, c, &cam, REFL_DEPTH_CONVENTION_LINEAR, REFL_DEPTH_CONVENTION_ZERO_TO_ONE, refl_row_range{0, kH}),
                 REFL_STATUS_OK);
    CHECK_STATUS(
        refl_image_convert_depth(m, c, &cam, REFL_DEPTH_CONVENTION_ZERO_TO_ONE, REFL_DEPTH_CONVENTION_REVERSED_Z, refl_row_range{0, kH}),
        REFL_STATUS_OK);
    CHECK_STATUS(refl_image_convert_depth(m, c, &cam, REFL_DEPTH_CONVENTION_REVERSED_Z, REFL_DEPTH_CONVENTION_LINEAR, refl_row_range{0, kH}),
                 REFL_STATUS_OK);
    double worst_in_place = 0.0;
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kSrcStride; ++x) {
            const size_t i = size_t(y) * kSrcStride + x;
            if (x >= kW) {
                CHECK(same_bits(buf[i], linear[i]));
                continue;
            }
            worst_in_place = std::max(worst_in_place, std::fabs(double(buf[i]) - linear[i]) / linear[i]);
        }
    // Post-projection depth in f32 resolves z to about (z / near) ulps of
    // relative error; a round trip takes two such roundings.
    const double bound = 4.0 * (zmax / cam.z_near) * 1.1920929e-7;
    std::printf("[%s] %ux%u, %ld convention pairs, %u threads: banded == one call, texels == per-texel functions;"
                " worst relative round-trip error %.3e, in-place chain %.3e (bound %.3e)\n",
                name, kW, kH, pairs, kThreads, worst_round_trip, worst_in_place, bound);
    CHECK(worst_round_trip < bound);
    CHECK(worst_in_place < bound);
}

}  // namespace

int main() {
    refl_camera cam;
    REQUIRE(refl_camera_look_at(&cam, refl_vec3{0, 1, 4}, refl_vec3{0, 0, 0}, refl_vec3{0, 1, 0}, 1.0f, 0.1f, 500.0f,
                                kW, kH) == REFL_STATUS_OK);
    run(cam, "far 500");
    cam.z_far = INFINITY;
    run(cam, "far inf");
    return check::finish("convert_depth");
}
