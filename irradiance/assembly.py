"""Stage 4 of :func:`widesky.irradiance.poa_irradiance`: the responses' parts, block by block.

:func:`assemble_parts` turns a chunk's columns into each response's direct, sky-diffuse and reflected
parts with the optics applied (the beam's exactly at each step's angle of incidence), averaged over each
face's points; :func:`assemble_blocks` runs the products and the assembly over the output blocks of
consecutive steps, hands each chunk to a consumer and each block to the sink (bounded memory).
"""

from __future__ import annotations

import time

import numpy as np
from tqdm.auto import tqdm

from .products import GlobalParts, ProductContext, chunk_products, dot3
from .result import PARTS

__all__ = ["assemble_parts", "assemble_blocks"]


def assemble_blocks(ctx: ProductContext, cols, plan, sink, scene, states, sky_terms, consumer=None,
                    progress=False, faces=None):
    """Stages 3 and 4 over every output block of ``plan`` (:class:`~widesky.irradiance.output_plan.OutputPlan`):
    the beam's angle of incidence, per chunk :func:`chunk_products` and :func:`assemble_parts` from the
    columns ``cols`` and the contracted sky ``sky_terms``, the ``consumer``, invalid faces zeroed, each
    block flushed to ``sink``; ``faces`` (f0, f1): the block of faces ``ctx`` holds (default all). Returns the
    seconds spent in (the products and assembly, the consumer)."""
    f0, f1 = (0, scene.n_faces) if faces is None else (int(faces[0]), int(faces[1]))
    kw = {"faces": slice(f0, f1)} if plan.consumer_faces else {}
    cf = ctx.cf
    up, sun_rank, chunk_plan = plan.up, plan.sun_rank, plan.chunks
    t_prod = t_consumer = 0.0
    ci = 0
    bar = None
    if progress:
        bar = tqdm(total=len(chunk_plan), unit="chunk", desc="time series")
    face_nT = np.ascontiguousarray(np.asarray(scene.face_normal[f0:f1], dtype=np.float32).T)
    sun_dir32 = states.sun_direction.astype(np.float32)
    invalid = ~scene.face_valid[f0:f1]
    for bi, (b0, b1) in enumerate(plan.blocks):
        if b1 <= b0:
            continue
        block = sink.block(b0, b1, f0, f1)
        upb = np.nonzero(up[b0:b1])[0]
        if upb.size and "aoi" in block:            # beam angle of incidence of every face
            cz = dot3(sun_dir32[b0 + upb], face_nT)
            np.clip(cz, -1.0, 1.0, out=cz)
            np.arccos(cz, out=cz)
            cz *= np.float32(180.0 / np.pi)
            block["aoi"][upb] = cz
        while ci < len(chunk_plan) and chunk_plan[ci][0] == bi:
            idx = chunk_plan[ci][1]
            band = np.full(idx.size, -1)
            band[up[idx]] = cf.step_band(sun_rank[idx[up[idx]]])
            order = np.argsort(band, kind="stable")          # steps of one shading cell together
            idx, band = idx[order], band[order]
            Lp, dni = sky_terms.take(idx)
            t1 = time.perf_counter()
            terms = chunk_products(ctx, idx, Lp, dni, up, sun_rank, band)
            currents = assemble_parts(ctx, cols.resp, cols.col_of, cols.plan, terms, block, idx - b0,
                                      plan.names, plan.stored)
            if consumer is not None:
                if np.any(invalid):
                    for v in block.values():
                        v[np.ix_(idx - b0, np.nonzero(invalid)[0])] = 0
                    for gp in currents.values():
                        gp.diffuse[:, invalid] = 0
                        gp.beam[:, invalid] = 0
                t_prod += time.perf_counter() - t1
                t1 = time.perf_counter()
                consumer(idx, block, idx - b0, currents, **kw)
                t_consumer += time.perf_counter() - t1
                t1 = time.perf_counter()
            t_prod += time.perf_counter() - t1
            ci += 1
            if bar is not None:
                bar.update(1)
        if np.any(invalid):
            for v in block.values():
                v[:, invalid] = 0
        sink.flush(b0, block, f0)
    if bar is not None:
        bar.close()
    return t_prod, t_consumer


def assemble_parts(ctx: ProductContext, resp, col_of, plan, terms, block, rows, names, stored=None):
    """Stage 4: each response's direct, sky-diffuse and reflected parts from its columns, the
    optics applied, averaged over each face's points, into ``block`` at ``rows``.

    ``stored`` (per response, from :func:`stored_parts`; default the three parts) names the parts
    kept; "global" is the float32 sum ``direct + sky_diffuse + ground_diffuse`` of the face means
    (what ``POAResult.get(name, "global")`` sums from the three), or for the fused columns their
    :class:`GlobalParts` total. An angle-only optic is evaluated once per chunk for all the
    responses that share it. Returns dict name -> :class:`GlobalParts` of the responses kept as
    "global" only or not at all.
    """
    sky_all, refl_all, beam, dni = terms["sky"], terms["refl"], terms["beam"], terms["dni"]
    Tc = beam.shape[0]
    aoi_pt = None
    f = ctx.faces
    b_dir, b_sky, b_ref = (b[:Tc] for b in ctx.buf_part)
    optic_at_aoi = {}                              # id(angular callable) -> (Tc, N) factor
    sp = ctx.slow_pos
    fast = {i: (j, m) for i, j, m in ctx.fast}
    fast_beam = {}
    currents = {}
    for i, (name, _w, _unit, r) in enumerate(resp):
        kind = plan.kind[i]
        js = col_of[i]
        if kind == "spectral" and aoi_pt is None:
            aoi_pt = np.degrees(np.arccos(np.clip(terms["cos"], 0.0, 1.0)))
        if kind == "angular":
            key = id(r.angular)
            if key not in optic_at_aoi:            # it multiplies the beam: only where that arrives
                optic_at_aoi[key] = _optic_on_beam(ctx, r.angular, terms)
        keep = PARTS if stored is None else stored[i]
        if i in fast:
            j, m = fast[i]
            if m not in fast_beam:                 # face mean of beam x optic, shared by the columns
                fast_beam[m] = f(beam) if m < 0 else f(np.multiply(
                    beam, optic_at_aoi[id(r.angular)], out=ctx.buf_fbeam[m][:Tc] if ctx.k == 1 else None))
            gp = GlobalParts(terms["fast"][m][:, ctx.fast_cols[m].index(j)], dni[:, j], fast_beam[m])
            currents[name] = gp
            if keep:
                block[(name, "global")][rows] = gp.total(out=b_dir[:, :ctx.F])
            continue
        if kind == "none":
            j = sp[js[0]]
            direct = np.multiply(dni[:, js[0]:js[0] + 1], beam, out=b_dir)
            skyd = sky_all[:, j]
            refl = refl_all[:, j]
        elif kind == "angular":
            j = sp[js[0]]
            g = optic_at_aoi[id(r.angular)]
            direct = np.multiply(dni[:, js[0]:js[0] + 1], beam, out=b_dir)
            direct *= g
            skyd = sky_all[:, j]
            refl = np.multiply(refl_all[:, j], ctx.refl_factor[plan.index[i]][None, :], out=b_ref)
        else:
            direct, skyd, refl = b_dir, b_sky, b_ref
            for b in (direct, skyd, refl):
                b.fill(0.0)
            eye = np.eye(plan.nodes.size)
            for a, j in enumerate(js):
                hat = np.interp(aoi_pt, plan.nodes, eye[a]).astype(np.float32)
                hat *= beam
                hat *= dni[:, j:j + 1]
                direct += hat
                skyd += sky_all[:, sp[j]]
                refl += refl_all[:, sp[j]] * ctx.refl_factor[plan.index[i] + a][None, :]
        if keep == PARTS:
            block[(name, "direct")][rows] = f(direct)
            block[(name, "sky_diffuse")][rows] = f(skyd)
            block[(name, "ground_diffuse")][rows] = f(refl)
            continue
        means = {"direct": f(direct), "sky_diffuse": f(skyd), "ground_diffuse": f(refl)}
        tot = None
        if "global" in keep or not keep:
            tot = np.array(means["direct"], dtype=np.float32)
            tot += means["sky_diffuse"]
            tot += means["ground_diffuse"]
        if not keep:                               # for the consumer only
            currents[name] = GlobalParts(tot, np.zeros(Tc, np.float32), np.zeros_like(tot))
        for p in keep:
            block[(name, p)][rows] = tot if p == "global" else means[p]
    if "sun_visible" in block:
        block["sun_visible"][rows] = f(terms["vis"])
    if ctx.spectral:
        J, C = ctx.J, ctx.C
        s0 = sp[J]
        sd = sky_all[:, s0:s0 + C].transpose(0, 2, 1)
        rd = refl_all[:, s0:s0 + C].transpose(0, 2, 1)
        dd = beam[:, :, None] * dni[:, None, J:J + C]
        for p, v in (("direct", dd), ("sky_diffuse", sd), ("ground_diffuse", rd)):
            block[("spectral", p)][rows] = _face_mean_spectral(ctx, v)
        block[("spectral", "global")][rows] = sum(block[("spectral", p)][rows] for p in PARTS)
    return currents


def _optic_on_beam(ctx, angular, terms):
    """(Tc, N) float32 angular optic at each point's beam angle of incidence [1]: per distinct
    normal (``ctx.normal_groups``) then spread, else where the beam arrives (0 elsewhere)."""
    if ctx.normal_groups is not None:
        aoi = np.degrees(np.arccos(np.clip(terms["cos_u"], 0.0, 1.0)))
        return np.asarray(angular(aoi), dtype=np.float32)[:, ctx.normal_groups[1]]
    beam = terms["beam"]
    lit = beam > 0
    g = np.zeros(beam.shape, np.float32)
    if lit.any():
        g[lit] = np.asarray(angular(np.degrees(np.arccos(np.clip(terms["cos"][lit], 0.0, 1.0)))),
                            dtype=np.float32)
    return g


def _face_mean_spectral(ctx, v):
    """(Tc, N, C) -> (Tc, F, C)."""
    k = ctx.k
    return v if k == 1 else v.reshape(v.shape[0], ctx.F, k, v.shape[2]).mean(axis=2)
