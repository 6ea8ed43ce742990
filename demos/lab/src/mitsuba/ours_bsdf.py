"""Our BRDFs as a Mitsuba 3 BSDF plugin (written by `demo --export DIR` beside scene.xml).

f = rho_d/pi + f_s, with f_s one of (twins: engine::math::brdf, shaders-glsl/common/brdf.glsl):
- Blinn-Phong        k_s (s+8)/(8 pi) (n.h)^s;
- Cook-Torrance      D(h) F(v.h) G1(v) G1(l) / (4 (n.l)(n.v)), Beckmann or GGX of width alpha, Schlick F with
                     F0 = k_s, Smith G1 (GGX exact, Beckmann by Walter et al. 2007's rational fit);
- Ashikhmin-Shirley  sqrt((n_u+1)(n_v+1))/(8 pi) (n.h)^((n_u (h.t)^2 + n_v (h.b)^2)/(1-(n.h)^2)) F(v.h)
                     / ((v.h) max(n.l, n.v)), t the material's world direction projected on the tangent plane.
k_s = 0 means no specular layer. The diffuse term needs n.l > 0, the specular one n.l > 0 and n.v > 0.

Two-sided like our G-buffer, which turns the normal toward the viewer: where the view direction is below the
shading frame's horizon both directions are mirrored through the tangent plane (what Mitsuba's `twosided` does).

Sampling is the reference's (shaders-glsl/shade/reference/integrate.glsl): the specular half-vector density
(Blinn-Phong (s+1)/(2 pi) (n.h)^s, Cook-Torrance D(h)(n.h), Ashikhmin-Shirley's Eq. 9) with probability
p = mean(k_s)/(mean(k_s)+mean(rho_d)), else cosine-weighted; the solid-angle density is the mixture
(1-p) (n.l)/pi + p pdf_h(h)/(4 v.h). Works in the scalar and the JIT (llvm_*/cuda_*) RGB variants.

Usage: `import ours_bsdf` after `mi.set_variant(...)` registers the plugin `ours` (render.py does it).
"""

import drjit as dr
import mitsuba as _mitsuba


class _Variant:
    """The variant's types, bound once at import: before 3.6 Mitsuba's variant is per thread, and the scalar
    renderer calls the plugin from worker threads that never set one."""


mi = _Variant()
for _name in ("BSDF", "BSDFFlags", "BSDFSample3f", "Color3f", "Frame3f", "ParamFlags", "UInt32", "Vector3f", "warp",
              "register_bsdf"):
    setattr(mi, _name, getattr(_mitsuba, _name))

MODELS = {"blinn-phong": 0, "cook-torrance-beckmann": 1, "cook-torrance-ggx": 2, "ashikhmin-shirley": 3}
_PI = 3.14159265358979323846


def _schlick(ks, c):
    x = 1.0 - dr.clip(c, 0.0, 1.0)
    x2 = x * x
    return ks + (1.0 - ks) * (x2 * x2 * x)


def _ndf(ggx, c, alpha):
    """Beckmann or GGX D(cos theta_h) (twin: brdf_ndf)."""
    a2 = alpha * alpha
    c2 = c * c
    if ggx:
        d = (a2 - 1.0) * c2 + 1.0
        v = a2 / (_PI * d * d)
    else:
        c2s = dr.maximum(c2, 1e-30)
        v = dr.exp((c2 - 1.0) / (c2s * a2)) / (_PI * a2 * c2s * c2s)
    return dr.select(c > 0.0, v, 0.0)


def _smith_g1(ggx, alpha, c):
    """Smith G1 (twin: brdf_smith_g1)."""
    cc = dr.minimum(c, 1.0)
    s2 = dr.maximum(1.0 - cc * cc, 0.0)
    if ggx:
        g = 2.0 * cc / dr.maximum(cc + dr.sqrt(cc * cc + alpha * alpha * s2), 1e-30)
    else:
        s = dr.sqrt(s2)
        a = cc / dr.maximum(alpha * s, 1e-30)
        g = dr.select(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a))
        g = dr.select(alpha * s <= 0.0, 1.0, g)
    return dr.select(c > 0.0, g, 0.0)


def _as_power(nu, nv, x, y, nh):
    """Ashikhmin-Shirley (n.h)^e(h), x = h.t, y = h.b (twin: brdf_as_power, brdf_ln_cos_over_sin2)."""
    s2 = x * x + y * y
    ln = dr.select(s2 < 1e-3, -0.5 * (1.0 + s2 * (0.5 + s2 / 3.0)),
                   dr.log(dr.maximum(nh, 1e-30)) / dr.maximum(s2, 1e-30))
    return dr.select(nh > 0.0, dr.exp((nu * x * x + nv * y * y) * ln), 0.0)


def _basis_t(z):
    """First vector of the Duff et al. 2017 basis around unit z (twin: common/frame.glsl orthonormal_basis)."""
    s = dr.select(z.z >= 0.0, 1.0, -1.0)
    a = -1.0 / (s + z.z)
    c = z.x * z.y * a
    return mi.Vector3f(1.0 + s * z.x * z.x * a, s * c, -s * z.x)


class OursBSDF(mi.BSDF):
    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        model = props.get("model", "blinn-phong")
        if model not in MODELS:
            raise ValueError(f"ours: unknown model '{model}' (one of {', '.join(MODELS)})")
        self.model_name = model
        self.model = MODELS[model]
        f = lambda key, default=0.0: float(props.get(key, default))
        self.kd_s = [f("kd_r"), f("kd_g"), f("kd_b")]
        self.ks_s = [f("ks_r"), f("ks_g"), f("ks_b")]
        self.kd = mi.Color3f(*self.kd_s)
        self.ks = mi.Color3f(*self.ks_s)
        self.s = f("s", 1.0)
        self.alpha = f("alpha", 0.1)
        self.nu = f("nu", 100.0)
        self.nv = f("nv", 100.0)
        self.tangent = mi.Vector3f(f("tangent_x"), f("tangent_y", 1.0), f("tangent_z"))
        self.tangent_len2 = f("tangent_x") ** 2 + f("tangent_y", 1.0) ** 2 + f("tangent_z") ** 2
        self.has_specular = any(k != 0.0 for k in self.ks_s)
        mean_kd, mean_ks = sum(self.kd_s) / 3.0, sum(self.ks_s) / 3.0
        # Probability of sampling the specular lobe (integrate.glsl specular_choice).
        self.p_spec = mean_ks / (mean_ks + mean_kd) if self.has_specular and mean_ks + mean_kd > 0.0 else 0.0
        # Plain ints: BSDFFlags' operators differ between Mitsuba versions.
        front_back = int(mi.BSDFFlags.FrontSide) | int(mi.BSDFFlags.BackSide)
        diffuse = int(mi.BSDFFlags.DiffuseReflection) | front_back
        glossy = int(mi.BSDFFlags.GlossyReflection) | front_back
        self.m_components = [diffuse, glossy] if self.has_specular else [diffuse]
        self.m_flags = (diffuse | glossy) if self.has_specular else diffuse

    # ---- the local frame: n = +z, mirrored where the viewer is below it ----
    def _frame(self, si):
        """(flip, t): flip where the view is below the shading frame; t the unit tangent in local coordinates
        (Ashikhmin-Shirley only), from the world normal turned toward the viewer, as the G-buffer turns it."""
        flip = mi.Frame3f.cos_theta(si.wi) < 0.0
        if self.model != 3:
            return flip, None
        n_w = dr.select(flip, -si.sh_frame.n, si.sh_frame.n)
        d = self.tangent
        p = d - dr.dot(d, n_w) * n_w
        l2 = dr.dot(p, p)
        t_w = dr.select(l2 > 1e-8 * max(self.tangent_len2, 1e-30), p * dr.rsqrt(dr.maximum(l2, 1e-30)), _basis_t(n_w))
        # Both n_w and its mirror have local z = ±1: the tangent's local x, y are the same in both frames.
        t = si.to_local(t_w)
        t = mi.Vector3f(t.x, t.y, 0.0)
        t = t * dr.rsqrt(dr.maximum(dr.dot(t, t), 1e-30))
        return flip, t

    @staticmethod
    def _mirror(w, flip):
        return mi.Vector3f(w.x, w.y, dr.select(flip, -w.z, w.z))

    def _specular(self, t, v, l):
        """f_s(l, v) in the local frame (n = z), without the cosine (twin: brdf_specular)."""
        nl, nv = l.z, v.z
        hv = l + v
        length = dr.norm(hv)
        h = hv / dr.maximum(length, 1e-30)
        nh = dr.maximum(h.z, 0.0)
        vh = dr.maximum(dr.dot(v, h), 0.0)
        ok = (nl > 0.0) & (nv > 0.0) & (length > 0.0)
        if self.model == 0:
            s = self.s
            f = self.ks * ((s + 8.0) / (8.0 * _PI) * dr.power(nh, s))
        elif self.model in (1, 2):
            ggx = self.model == 2
            d = _ndf(ggx, nh, self.alpha)
            g = _smith_g1(ggx, self.alpha, nv) * _smith_g1(ggx, self.alpha, nl)
            f = _schlick(self.ks, vh) * (d * g / dr.maximum(4.0 * nl * nv, 1e-30))
        else:
            b = mi.Vector3f(-t.y, t.x, 0.0)  # n x t
            p = _as_power(self.nu, self.nv, dr.dot(h, t), dr.dot(h, b), nh)
            c = dr.sqrt((self.nu + 1.0) * (self.nv + 1.0)) / (8.0 * _PI)
            f = _schlick(self.ks, vh) * (c * p / dr.maximum(vh * dr.maximum(nl, nv), 1e-12))
            ok &= vh > 0.0
        return dr.select(ok, f, mi.Color3f(0.0))

    def _half_pdf(self, t, h):
        """Density over half vectors of the specular sampling (twin: brdf_half_pdf)."""
        nh = h.z
        if self.model == 0:
            p = (self.s + 1.0) / (2.0 * _PI) * dr.power(dr.maximum(nh, 0.0), self.s)
        elif self.model in (1, 2):
            p = _ndf(self.model == 2, nh, self.alpha) * nh
        else:
            b = mi.Vector3f(-t.y, t.x, 0.0)
            c = dr.sqrt((self.nu + 1.0) * (self.nv + 1.0)) / (2.0 * _PI)
            p = c * _as_power(self.nu, self.nv, dr.dot(h, t), dr.dot(h, b), nh)
        return dr.select(nh > 0.0, p, 0.0)

    def _sample_half(self, t, u1, u2):
        """A half vector distributed by _half_pdf (twin: brdf_sample_half)."""
        if self.model == 0:
            cos_h = dr.power(1.0 - u1, 1.0 / (self.s + 1.0))
            phi = 2.0 * _PI * u2
        elif self.model in (1, 2):
            a2 = self.alpha * self.alpha
            if self.model == 2:
                tan2 = a2 * u1 / dr.maximum(1.0 - u1, 1e-30)
            else:
                tan2 = -a2 * dr.log(dr.maximum(1.0 - u1, 1e-30))
            cos_h = dr.rsqrt(1.0 + tan2)
            phi = 2.0 * _PI * u2
        else:
            nu, nv = self.nu, self.nv
            q = dr.floor(4.0 * u2)
            u = 4.0 * u2 - q
            p0 = dr.atan(dr.sqrt((nu + 1.0) / (nv + 1.0)) * dr.tan(0.5 * _PI * dr.minimum(u, 0.999999)))
            # The quadrant by `<` (q is an integer-valued float; `==` on it is not reliable across drjit versions).
            phi = dr.select(q < 0.5, p0, dr.select(q < 1.5, _PI - p0, dr.select(q < 2.5, _PI + p0, 2.0 * _PI - p0)))
            cp, sp = dr.cos(phi), dr.sin(phi)
            cos_h = dr.power(1.0 - u1, 1.0 / (nu * cp * cp + nv * sp * sp + 1.0))
        sin_h = dr.safe_sqrt(1.0 - cos_h * cos_h)
        if self.model == 3:
            b = mi.Vector3f(-t.y, t.x, 0.0)
            h = sin_h * dr.cos(phi) * t + sin_h * dr.sin(phi) * b + mi.Vector3f(0.0, 0.0, cos_h)
        else:
            # Isotropic: any frame around n.
            h = mi.Vector3f(sin_h * dr.cos(phi), sin_h * dr.sin(phi), cos_h)
        return dr.normalize(h)

    def _eval(self, t, v, l):
        f = self.kd * (1.0 / _PI)
        if self.has_specular:
            f = f + self._specular(t, v, l)
        # (A typed zero: in scalar variants select() with a Python bool returns the chosen operand as is.)
        return dr.select(l.z > 0.0, f * l.z, mi.Color3f(0.0))

    def _pdf(self, t, v, l):
        """Solid-angle density of the mixture (integrate.glsl brdf_pdf)."""
        pdf = (1.0 - self.p_spec) * dr.maximum(l.z, 0.0) / _PI
        if self.p_spec > 0.0:
            hv = v + l
            length = dr.norm(hv)
            h = hv / dr.maximum(length, 1e-30)
            vh = dr.dot(v, h)
            spec = self.p_spec * self._half_pdf(t, h) / dr.maximum(4.0 * vh, 1e-30)
            pdf = pdf + dr.select((length > 0.0) & (h.z > 0.0) & (vh > 0.0), spec, 0.0)
        return pdf

    # ---- the mi.BSDF interface ----
    def sample(self, ctx, si, sample1, sample2, active=True):
        flip, t = self._frame(si)
        v = self._mirror(si.wi, flip)
        choose_spec = sample1 < self.p_spec
        if self.p_spec > 0.0:
            h = self._sample_half(t, sample2.x, sample2.y)
            l_spec = 2.0 * dr.dot(v, h) * h - v
            l = dr.select(choose_spec, l_spec, mi.warp.square_to_cosine_hemisphere(sample2))
        else:
            l = mi.warp.square_to_cosine_hemisphere(sample2)
        pdf = self._pdf(t, v, l)
        value = self._eval(t, v, l)
        ok = (pdf > 0.0) & (l.z > 0.0)
        bs = mi.BSDFSample3f()
        bs.wo = self._mirror(l, flip)
        bs.pdf = dr.select(ok, pdf, 0.0)
        bs.eta = 1.0
        bs.sampled_component = dr.select(choose_spec, mi.UInt32(1), mi.UInt32(0))
        bs.sampled_type = dr.select(choose_spec, mi.UInt32(+mi.BSDFFlags.GlossyReflection),
                                    mi.UInt32(+mi.BSDFFlags.DiffuseReflection))
        return bs, dr.select(ok, value / dr.maximum(pdf, 1e-30), mi.Color3f(0.0))

    def eval(self, ctx, si, wo, active=True):
        flip, t = self._frame(si)
        return self._eval(t, self._mirror(si.wi, flip), self._mirror(wo, flip))

    def pdf(self, ctx, si, wo, active=True):
        flip, t = self._frame(si)
        return self._pdf(t, self._mirror(si.wi, flip), self._mirror(wo, flip))

    def eval_pdf(self, ctx, si, wo, active=True):
        flip, t = self._frame(si)
        v, l = self._mirror(si.wi, flip), self._mirror(wo, flip)
        return self._eval(t, v, l), self._pdf(t, v, l)

    def eval_diffuse_reflectance(self, si, active=True):
        return self.kd

    def traverse(self, callback):
        # Mitsuba >= 3.6 names it put(), earlier versions put_parameter().
        put = getattr(callback, "put", None) or getattr(callback, "put_parameter")
        put("kd", self.kd, mi.ParamFlags.NonDifferentiable)
        put("ks", self.ks, mi.ParamFlags.NonDifferentiable)

    def parameters_changed(self, keys):
        # kd/ks edited through mi.traverse are used as they are by eval; the lobe choice p_spec keeps its value
        # from construction, which leaves the estimator unbiased (any 0 < p < 1 is), only its variance changes.
        pass

    def to_string(self):
        return (f"OursBSDF[model={self.model_name}, kd={self.kd_s}, ks={self.ks_s}, s={self.s}, alpha={self.alpha}, "
                f"nu={self.nu}, nv={self.nv}, p_spec={self.p_spec:.6f}]")


mi.register_bsdf("ours", lambda props: OursBSDF(props))
