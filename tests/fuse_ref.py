"""The key light over views (light/fuse.h), written again in Python for the tests to check the C
against: views as {bin: [lights in world space]} (the bin only says which views replace each
other), each view's lights at unit total energy, lobes no narrower than 1 - cos 6 deg, the best
direction of the same 1024-point Fibonacci sphere, then the mean shift. Returns the unit
direction, or None when no view holds light."""
import math


def sg_integral(sr):
    s = sr / (4 * math.pi)
    return 2 * math.pi * s * -math.expm1(-2 / s)


def lum(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


def energy(light):
    return lum(light["rgb"]) * sg_integral(light["solid_angle_sr"])


def key_light(views):
    lobes = []
    sigma_min = 1 - math.cos(math.radians(6))
    for lights in views.values():
        tot = sum(energy(l) for l in lights)
        if not tot > 0:
            continue
        for l in lights:
            e = energy(l)
            if e <= 0:
                continue
            s = max(l["solid_angle_sr"] / (4 * math.pi), sigma_min)
            n = math.sqrt(sum(x * x for x in l["dir"]))
            lobes.append(([x / n for x in l["dir"]], e / tot / sg_integral(4 * math.pi * s), 1 / s))
    if not lobes:
        return None

    def at(u):
        return sum(w * math.exp(k * (u[0] * d[0] + u[1] * d[1] + u[2] * d[2] - 1)) for d, w, k in lobes)

    best, best_e = None, -1.0
    for j in range(1024):
        y = 1 - 2 * (j + 0.5) / 1024
        r = math.sqrt(1 - y * y)
        t = j * math.pi * (3 - math.sqrt(5))
        u = (r * math.cos(t), y, r * math.sin(t))
        e = at(u)
        if e > best_e:
            best, best_e = u, e
    for _ in range(100):
        g = [0.0, 0.0, 0.0]
        for d, w, k in lobes:
            x = w * k * math.exp(k * (best[0] * d[0] + best[1] * d[1] + best[2] * d[2] - 1))
            for q in range(3):
                g[q] += x * d[q]
        n = math.sqrt(sum(x * x for x in g))
        best = [x / n for x in g]
    return best


def angle_deg(a, b):
    na = math.sqrt(sum(x * x for x in a))
    nb = math.sqrt(sum(x * x for x in b))
    d = sum(x * y for x, y in zip(a, b)) / (na * nb)
    return math.degrees(math.acos(max(-1.0, min(1.0, d))))


def yaw_to_world(yaw_deg, v):
    """A direction in the camera frame of `parlight crop`/`eval`'s crop at this yaw (pitch 0)
    into the panorama's frame: a turn about y by -yaw (the camera looks along -z at yaw 0)."""
    a = math.radians(yaw_deg)
    return [math.cos(a) * v[0] - math.sin(a) * v[2], v[1], math.sin(a) * v[0] + math.cos(a) * v[2]]
