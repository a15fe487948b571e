// Orientation and in-circle determinants in the image plane (row, column).
//
// Integer coordinates make both exact in int64 for images up to about 30,000 pixels a side;
// the floating-point forms are the same expressions, evaluated in the order written (no
// contraction), so they round exactly as the Python references do.
#pragma once

namespace rangemesh {

// Twice the signed area of (a, b, c); > 0 when counter-clockwise in (row, column).
template <class T>
inline T orient(T ra, T ca, T rb, T cb, T rc, T cc) {
    return (rb - ra) * (cc - ca) - (cb - ca) * (rc - ra);
}

// > 0 when d lies strictly inside the circle through the counter-clockwise a, b, c.
template <class T>
inline T incircle(T ar, T ac, T br, T bc, T cr, T cc, T dr, T dc) {
    const T adr = ar - dr, adc = ac - dc;
    const T bdr = br - dr, bdc = bc - dc;
    const T cdr = cr - dr, cdc = cc - dc;
    const T ad = adr * adr + adc * adc;
    const T bd = bdr * bdr + bdc * bdc;
    const T cd = cdr * cdr + cdc * cdc;
    return adr * (bdc * cd - bd * cdc) - adc * (bdr * cd - bd * cdr) + ad * (bdr * cdc - bdc * cdr);
}

// Python's floor division and modulo for a positive divisor (C++ truncates toward zero).
inline long long floor_div(long long a, long long d) {
    long long q = a / d;
    return (a % d != 0 && a < 0) ? q - 1 : q;
}

}  // namespace rangemesh
