#include "flare/ghosts/MarginModel.h"

#include <algorithm>
#include <cmath>

namespace flare {

namespace {

// The cell's corners in cell units, counter-clockwise from its lower-left one.
constexpr long kCorners[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};

}  // namespace

MarginModel fitMarginModel(const double block[4][4], double cellMm) {
    MarginModel model;
    const double h = cellMm;
    int valued = 0;
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) valued += !std::isnan(block[y][x]);
    if (valued < 3) return model;
    double curvature = 0.0;  // largest second difference along rows and columns
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) {
            if (x < 2 && !std::isnan(block[y][x] + block[y][x + 1] + block[y][x + 2]))
                curvature = std::max(curvature, std::abs(block[y][x] - 2.0 * block[y][x + 1] + block[y][x + 2]));
            if (y < 2 && !std::isnan(block[y][x] + block[y + 1][x] + block[y + 2][x]))
                curvature = std::max(curvature, std::abs(block[y][x] - 2.0 * block[y + 1][x] + block[y + 2][x]));
        }
    model.curvaturePerMm2 = curvature / (h * h);
    // Least squares plane m ≈ p0 + px·u + py·v, u and v in cells from the cell's lower corner.
    double a[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, b[3] = {0, 0, 0};
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) {
            if (std::isnan(block[y][x])) continue;
            const double f[3] = {1.0, x - 1.0, y - 1.0};
            for (int r = 0; r < 3; ++r) {
                b[r] += f[r] * block[y][x];
                for (int q = 0; q < 3; ++q) a[r][q] += f[r] * f[q];
            }
        }
    auto det3 = [](const double m[3][3]) {
        return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    };
    const double det = det3(a);
    if (!(std::abs(det) > 1e-9)) return model;  // the points are collinear
    double p[3];
    for (int col = 0; col < 3; ++col) {
        double m[3][3];
        for (int r = 0; r < 3; ++r)
            for (int q = 0; q < 3; ++q) m[r][q] = q == col ? b[r] : a[r][q];
        p[col] = det3(m) / det;
    }
    model.p0 = p[0], model.px = p[1], model.py = p[2];
    double residual = 0.0;  // at the cell's own corners
    for (int k = 0; k < 4; ++k) {
        const double m = block[1 + kCorners[k][1]][1 + kCorners[k][0]];
        if (!std::isnan(m)) residual = std::max(residual, std::abs(m - (p[0] + p[1] * kCorners[k][0] + p[2] * kCorners[k][1])));
    }
    model.allowance = residual;
    model.judged = true;
    return model;
}

CellPolygon clipBelow(const CellPolygon& polygon, double p0, double px, double py) {
    CellPolygon out;
    for (int k = 0; k < polygon.size; ++k) {
        const glm::dvec2 a = polygon.p[k], b = polygon.p[(k + 1) % polygon.size];
        const double fa = p0 + px * a.x + py * a.y, fb = p0 + px * b.x + py * b.y;
        if (fa <= 0.0 && out.size < 8) out.p[out.size++] = a;
        if ((fa <= 0.0) != (fb <= 0.0) && out.size < 8) out.p[out.size++] = a + (b - a) * (fa / (fa - fb));
    }
    return out;
}

double polygonArea(const CellPolygon& polygon) {
    double twice = 0.0;
    for (int k = 0; k < polygon.size; ++k) {
        const glm::dvec2 a = polygon.p[k], b = polygon.p[(k + 1) % polygon.size];
        twice += a.x * b.y - a.y * b.x;
    }
    return 0.5 * std::abs(twice);
}

}  // namespace flare
