"""DEM readers: LIGGGHTS / LAMMPS local dumps, generic CSV/NPZ tables, sign conventions, errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grainmech.errors import GrainmechError
from grainmech.io import _dem_blocks as blocks  # the block parser: what these tests patch
from grainmech.io import dem as demio
from grainmech.io._dem_dump import _read_particles_dump
from grainmech.io._dem_write import _box_header
from grainmech.io.dem import read_liggghts, read_network, write_liggghts, write_table
from grainmech.network import Box, lattice_network, network_stress, random_network
from grainmech.network.tables import lookup_rows

TRICLINIC = np.array([[10.0, 0, 0], [2.0, 9.0, 0], [1.0, -1.5, 11.0]])


@pytest.fixture(autouse=True, params=["pyarrow", "line-parser"])
def reader(request, monkeypatch):
    """Every test of this module runs with the pyarrow CSV path and with the NumPy line
    parser (the fallback without pyarrow): same arrays, same sign conventions, same errors."""
    if request.param == "pyarrow":
        pytest.importorskip("pyarrow")
    else:
        monkeypatch.setattr(blocks, "_arrow_csv", lambda: None)
    return request.param


def _direct_stress(pos, I, J, f_by_i_on_j, cell):
    """sigma = (1/V) sum f (x) l with l the minimum image of x_j - x_i (independent sum)."""
    inv = np.linalg.inv(cell)
    s = (pos[J] - pos[I]) @ inv
    s -= np.round(s)
    l_ = s @ cell
    full = np.einsum("ci,cj->ij", f_by_i_on_j, l_) / abs(np.linalg.det(cell))
    return 0.5 * (full + full.T)


@pytest.mark.parametrize("cell", [None, TRICLINIC], ids=["orthogonal", "triclinic"])
def test_liggghts_roundtrip_and_stress(tmp_path, cell):
    net = random_network(150, cell=cell, seed=9)
    c, p = tmp_path / "contacts.dump", tmp_path / "particles.dump"
    write_liggghts(net, c, p)
    # the file holds the force on the FIRST particle (LIGGGHTS convention): -f
    lines = c.read_text().splitlines()
    first = np.array(lines[lines.index(next(x for x in lines if x.startswith("ITEM: ENTRIES"))) + 1].split(),
                     dtype=float)
    np.testing.assert_allclose(first[9:12], -net.force[0], rtol=1e-15)
    back = read_network(c, p)
    np.testing.assert_allclose(back.force, net.force, rtol=0, atol=0)
    np.testing.assert_allclose(back.positions, net.positions, rtol=1e-15)
    np.testing.assert_allclose(back.radii, net.radii, rtol=1e-15)
    np.testing.assert_allclose(back.box.cell, net.box.cell, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(back.box.origin, net.box.origin, atol=1e-15)
    assert back.box.periodic.all()
    np.testing.assert_allclose(back.branch, net.branch, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(back.overlap, net.overlap, rtol=1e-12)
    assert back.contact_point is not None
    ref = _direct_stress(net.positions, net.i, net.j, net.force, net.box.cell)
    st = network_stress(back)
    np.testing.assert_allclose(st.stress, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())
    assert st.mean > 0  # compressive overlaps -> positive pressure
    # contacts only (positions from the 'pos' columns, box from the contact dump)
    only = read_liggghts(c)
    np.testing.assert_allclose(network_stress(only).stress, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())


def _two_particle_dump(path, force_on_first, header="c_fc[1] c_fc[2] c_fc[3] c_fc[4] c_fc[5] c_fc[6] "
                       "c_fc[7] c_fc[8] c_fc[9] c_fc[10] c_fc[11] c_fc[12]", extra=""):
    fx = force_on_first
    path.write_text(
        "ITEM: TIMESTEP\n100\nITEM: NUMBER OF ENTRIES\n1\nITEM: BOX BOUNDS pp ff pp\n"
        "0 10\n0 10\n0 10\n"
        f"ITEM: ENTRIES {header}\n"
        f"1 5 5 2.9 5 5 3 7 0 {fx} 0 0{extra}\n")


def _particles(path, rows="3 1 1 5 5 1.0\n7 1 2.9 5 5 1.0\n", header="id type x y z radius"):
    path.write_text("ITEM: TIMESTEP\n100\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS pp ff pp\n"
                    f"0 10\n0 10\n0 10\nITEM: ATOMS {header}\n{rows}")


def test_liggghts_sign_convention_two_spheres(tmp_path):
    """Particle 3 at x=1, particle 7 at x=2.9 (radii 1, overlap 0.1). The compressed contact
    pushes particle 3 (the first) towards -x: LIGGGHTS writes fx = -F on particle 3.
    grainmech: force by A=3 on B=7 is +F e_x, N = +F, sigma_xx = F * 1.9 / V > 0."""
    c, p = tmp_path / "c.dump", tmp_path / "p.dump"
    _two_particle_dump(c, -50.0)
    _particles(p)
    net = read_network(c, p)
    np.testing.assert_allclose(net.force, [[50.0, 0, 0]])
    np.testing.assert_allclose(net.branch, [[1.9, 0, 0]])
    np.testing.assert_allclose(net.normal_force, [50.0])
    np.testing.assert_array_equal(net.box.periodic, [True, False, True])
    st = network_stress(net)
    np.testing.assert_allclose(st.stress[0, 0], 50.0 * 1.9 / 1000.0)
    # across the periodic boundary: particle 7 at x=9.1 is 1.9 away from x=1 through x=0
    _particles(p, rows="3 1 1 5 5 1.0\n7 1 9.1 5 5 1.0\n")
    _two_particle_dump(c, +50.0)  # particle 3 now pushed towards +x
    net = read_network(c, p)
    np.testing.assert_allclose(net.branch, [[-1.9, 0, 0]], atol=1e-12)
    np.testing.assert_allclose(net.normal_force, [50.0])
    # declaring the opposite convention flips the sign
    net2 = read_liggghts(c, p, force_on="id2")
    np.testing.assert_allclose(net2.normal_force, [-50.0])


def test_liggghts_keywords_and_descriptive_headers(tmp_path):
    c, p = tmp_path / "c.dump", tmp_path / "p.dump"
    _particles(p)
    # 13 columns: pos,id,force,delta recognised from the width
    _two_particle_dump(c, -50.0, header=" ".join(f"c_x[{k}]" for k in range(1, 14)), extra=" 0.1")
    net = read_network(c, p)
    np.testing.assert_allclose(net.overlap, [0.1])
    # explicit keywords with history
    _two_particle_dump(c, -50.0, header=" ".join(f"c_x[{k}]" for k in range(1, 16)), extra=" 0.3 0.2 0.1")
    net = read_liggghts(c, p, keywords=["pos", "id", "force", "history:3"])
    np.testing.assert_allclose(net.force, [[50.0, 0, 0]])
    with pytest.raises(GrainmechError, match="keywords pos,id,force give 12 columns but the file has 15"):
        read_liggghts(c, p, keywords=["pos", "id", "force"])
    # descriptive names in any order
    c.write_text("ITEM: TIMESTEP\n1\nITEM: NUMBER OF ENTRIES\n1\nITEM: BOX BOUNDS pp pp pp\n0 10\n0 10\n0 10\n"
                 "ITEM: ENTRIES fz fy fx id2 id1\n0 0 -50 7 3\n")
    np.testing.assert_allclose(read_network(c, p).force, [[50.0, 0, 0]])


def test_unrecognised_width_asks_for_keywords(tmp_path):
    c, p = tmp_path / "c.dump", tmp_path / "p.dump"
    _particles(p)
    _two_particle_dump(c, -50.0, header=" ".join(f"c_x[{k}]" for k in range(1, 15)), extra=" 1 2")
    with pytest.raises(GrainmechError, match=r"c\.dump:9: cannot tell what the 14 columns"):
        read_network(c, p)


def test_lammps_local_dump(tmp_path):
    """compute property/local patom1 patom2 + compute pair/local fx fy fz (force on atom I)."""
    c, p = tmp_path / "c.dump", tmp_path / "p.dump"
    _particles(p)
    c.write_text("ITEM: TIMESTEP\n1\nITEM: NUMBER OF ENTRIES\n1\nITEM: BOX BOUNDS pp pp pp\n0 10\n0 10\n0 10\n"
                 "ITEM: ENTRIES index c_pp[1] c_pp[2] c_pl[1] c_pl[2] c_pl[3]\n1 3 7 -50 0 0\n")
    with pytest.raises(GrainmechError, match="--columns"):
        read_network(c, p, format="lammps")
    net = read_network(c, p, format="lammps", columns=["index", "id1", "id2", "fx", "fy", "fz"])
    np.testing.assert_allclose(net.normal_force, [50.0])
    np.testing.assert_allclose(network_stress(net).stress[0, 0], 50 * 1.9 / 1000)


def test_triclinic_box_and_scaled_coordinates(tmp_path):
    box = Box(np.array([1.0, -2.0, 0.5]), TRICLINIC, np.array([True, True, True]))
    lines = _box_header(box)
    assert lines[0] == "ITEM: BOX BOUNDS xy xz yz pp pp pp"
    # LAMMPS: xlo_bound = xlo + min(0, xy, xz, xy+xz), xhi_bound = xhi + max(...)
    np.testing.assert_allclose([float(v) for v in lines[1].split()], [1.0, 14.0, 2.0])
    np.testing.assert_allclose([float(v) for v in lines[2].split()], [-3.5, 7.0, 1.0])
    p = tmp_path / "p.dump"
    s = np.array([[0.1, 0.2, 0.3], [0.5, 0.5, 0.5]])
    p.write_text("ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\n" + "\n".join(lines) + "\n"
                 "ITEM: ATOMS id xs ys zs diameter\n" + "\n".join(f"{k + 1} {a} {b} {c} 2.0" for k, (a, b, c)
                                                                 in enumerate(s)) + "\n")
    parts = _read_particles_dump(p)
    np.testing.assert_allclose(parts.pos, box.origin + s @ TRICLINIC)
    np.testing.assert_allclose(parts.radii, [1.0, 1.0])
    np.testing.assert_allclose(parts.box.cell, TRICLINIC, atol=1e-14)


@pytest.mark.parametrize("suffix", ["csv", "npz"])
def test_generic_table_roundtrip(tmp_path, suffix):
    net = random_network(120, cell=TRICLINIC, seed=1)
    c, p = tmp_path / f"c.{suffix}", tmp_path / f"p.{suffix}"
    write_table(net, c, p)
    back = read_network(c, p)
    np.testing.assert_allclose(back.force, net.force, rtol=0, atol=0)
    np.testing.assert_allclose(back.branch, net.branch, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(back.box.cell, TRICLINIC)
    ref = _direct_stress(net.positions, net.i, net.j, net.force, TRICLINIC)
    np.testing.assert_allclose(network_stress(back).stress, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())


def test_generic_csv_sign_and_box_comment(tmp_path):
    c, p = tmp_path / "c.csv", tmp_path / "p.csv"
    p.write_text("# box: 0 10 0 10 0 10\nid,x,y,z,radius\n3,1,5,5,1\n7,2.9,5,5,1\n")
    c.write_text("id1,id2,fx,fy,fz\n3,7,50,0,0\n")  # force by 3 on 7: pushes 7 to +x
    net = read_network(c, p)
    np.testing.assert_allclose(net.normal_force, [50.0])
    assert net.volume == pytest.approx(1000.0)
    c.write_text("# force_on: id1\nid1,id2,fx,fy,fz\n3,7,-50,0,0\n")
    np.testing.assert_allclose(read_network(c, p).normal_force, [50.0])


# ---------------------------------------------------------------- errors name file, line, column, value

@pytest.mark.parametrize("row,match", [
    ("3,7,50,abc,0", r"c\.csv:3: column 'fy': value 'abc' is not a number"),
    ("3,7,50,0", r"c\.csv:3: expected 5 columns"),
    ("3,7,nan,0,0", r"c\.csv:3: column 'fx': value nan is not finite"),
    ("3,9,50,0,0", r"c\.csv:3: particle id 9 \(column id2\) is not listed in .*p\.csv"),
    ("3,3,50,0,0", r"c\.csv:3: contact of particle 3 with itself"),
    ("3.5,7,50,0,0", r"c\.csv:3: column 'id1': value 3.5 is not an integer id"),
])
def test_table_errors(tmp_path, row, match):
    c, p = tmp_path / "c.csv", tmp_path / "p.csv"
    p.write_text("# box: 0 10 0 10 0 10\nid,x,y,z,radius\n3,1,5,5,1\n7,2.9,5,5,1\n")
    c.write_text(f"id1,id2,fx,fy,fz\n3,7,50,0,0\n{row}\n")
    with pytest.raises(GrainmechError, match=match):
        read_network(c, p)


def test_missing_columns_and_bad_particles(tmp_path):
    c, p = tmp_path / "c.csv", tmp_path / "p.csv"
    p.write_text("id,x,y,z,radius\n3,1,5,5,1\n7,2.9,5,5,1\n")
    c.write_text("id1,id2,fx,fy\n3,7,50,0\n")
    with pytest.raises(GrainmechError, match=r"c\.csv:1: contact table has no 'fz' column"):
        read_network(c, p)
    p.write_text("id,x,y,radius\n3,1,5,1\n")
    c.write_text("id1,id2,fx,fy,fz\n3,7,50,0,0\n")
    with pytest.raises(GrainmechError, match=r"p\.csv:1: particle table needs columns x y z"):
        read_network(c, p)
    p.write_text("id,x,y,z,radius\n3,1,5,5,1\n3,2.9,5,5,1\n")
    with pytest.raises(GrainmechError, match=r"p\.csv:3: particle id 3 appears twice"):
        read_network(c, p)
    p.write_text("id,x,y,z,radius\n3,1,5,5,1\n7,2.9,5,5,-1\n")
    with pytest.raises(GrainmechError, match=r"p\.csv:3: particle 7: radius must be > 0"):
        read_network(c, p)


def test_dump_errors(tmp_path):
    c, p = tmp_path / "c.dump", tmp_path / "p.dump"
    _particles(p)
    _two_particle_dump(c, -50.0)
    text = c.read_text()
    c.write_text(text.replace("NUMBER OF ENTRIES\n1", "NUMBER OF ENTRIES\n2"))
    with pytest.raises(GrainmechError, match=r"c\.dump:10: file ends after 1 of 2 data rows"):
        read_network(c, p)
    c.write_text(text.replace(" 7 0 -50.0", " 7 0 inf"))
    with pytest.raises(GrainmechError, match=r"c\.dump:10: column 'c_fc\[10\]': value inf is not finite"):
        read_network(c, p)
    c.write_text(text.replace("ITEM: ENTRIES", "ITEM: ATOMS"))
    with pytest.raises(GrainmechError, match=r"c\.dump:9: expected 'ITEM: ENTRIES'"):
        read_network(c, p)
    _particles(p, rows="3 1 1 5 5 1.0\n8 1 2.9 5 5 1.0\n")
    c.write_text(text)
    with pytest.raises(GrainmechError, match=r"c\.dump:10: particle id 7 \(column id2\) is not listed"):
        read_network(c, p)
    with pytest.raises(GrainmechError, match="file not found"):
        read_network(tmp_path / "nope.dump", p)


def test_gzipped_dumps_read_like_the_plain_files(tmp_path):
    """A ``.gz`` contact or particle dump is decompressed on the fly: the same network as
    the plain files (bit for bit); a ``.gz`` name on data that is not gzip is a one-line error."""
    import gzip

    net = random_network(120, cell=TRICLINIC, seed=4)
    c, p = tmp_path / "contacts.dump", tmp_path / "particles.dump"
    write_liggghts(net, c, p)
    cz, pz = tmp_path / "contacts.dump.gz", tmp_path / "particles.dump.gz"
    cz.write_bytes(gzip.compress(c.read_bytes()))
    pz.write_bytes(gzip.compress(p.read_bytes()))
    plain = read_network(c, p)
    seen: list[tuple[int, int]] = []
    for cc, pp in ((cz, pz), (cz, p), (c, pz)):
        back = read_network(cc, pp, progress=lambda d, t: seen.append((d, t)))
        for name in ("force", "positions", "radii", "branch", "overlap", "contact_point"):
            np.testing.assert_array_equal(getattr(back, name), getattr(plain, name))
        np.testing.assert_array_equal(back.box.cell, plain.box.cell)
        np.testing.assert_array_equal(back.i, plain.i)
    assert demio.detect_format(cz) == "liggghts"
    # the generic CSV table too
    tc, tp = tmp_path / "contacts.csv", tmp_path / "particles.csv"
    write_table(net, tc, tp)
    tcz, tpz = tmp_path / "contacts.csv.gz", tmp_path / "particles.csv.gz"
    tcz.write_bytes(gzip.compress(tc.read_bytes()))
    tpz.write_bytes(gzip.compress(tp.read_bytes()))
    np.testing.assert_array_equal(read_network(tcz, tpz).force, read_network(tc, tp).force)
    assert all(d <= t for d, t in seen) and seen[-1][0] == seen[-1][1]
    bad = tmp_path / "broken.dump.gz"
    bad.write_bytes(c.read_bytes())
    with pytest.raises(GrainmechError, match=r"broken\.dump\.gz: not a gzip file"):
        read_network(bad, p)


@pytest.mark.parametrize("pids", [(3, 7), (3, 7_000_000_000)], ids=["id-table", "binary-search"])
@pytest.mark.parametrize("bad", [1, 5, 9, 8_000_000_000])
def test_unknown_particle_id_with_both_lookups(tmp_path, pids, bad):
    """Ids 3..7 are looked up in a table indexed by id, ids 3 and 7e9 by binary search:
    an unknown id below, between, above the listed ones is named with its line."""
    c, p = tmp_path / "c.dump", tmp_path / "p.dump"
    a, b = pids
    _particles(p, rows=f"{a} 1 1 5 5 1.0\n{b} 1 2.9 5 5 1.0\n")
    _two_particle_dump(c, -50.0)
    c.write_text(c.read_text().replace(" 3 7 0 ", f" {a} {b} 0 "))
    net = read_network(c, p)
    assert net.ids[net.i].tolist() == [a] and net.ids[net.j].tolist() == [b]
    c.write_text(c.read_text().replace(f" {a} {b} 0 ", f" {a} {bad} 0 "))
    with pytest.raises(GrainmechError, match=rf"c\.dump:10: particle id {bad} \(column id2\) is not listed"):
        read_network(c, p)


def test_lookup_table_and_binary_search_agree():
    """The two look-ups of lookup_rows give the rows a dict gives, unknown ids rejected."""
    rng = np.random.default_rng(7)
    for ids in (rng.permutation(np.arange(1, 5001)), rng.choice(10**12, 5000, replace=False)):
        order = np.argsort(ids, kind="stable")
        rows = {int(v): r for r, v in enumerate(ids)}
        q = ids[rng.integers(0, len(ids), 200_000)]
        got = lookup_rows(ids[order], order, q.copy(), Path("c"), 1, "id1", Path("p"))
        assert got.tolist() == [rows[int(v)] for v in q]
        q[150_000] = ids.max() + 1
        with pytest.raises(GrainmechError, match=rf"c:150001: particle id {ids.max() + 1} \(column id1\)"):
            lookup_rows(ids[order], order, q, Path("c"), 1, "id1", Path("p"))


def test_chunked_reading_matches(tmp_path, monkeypatch):
    net = lattice_network("fcc", 3, 1.0, 1e-3)
    c, p = tmp_path / "c.dump", tmp_path / "p.dump"
    write_liggghts(net, c, p)
    monkeypatch.setattr(blocks, "CHUNK_LINES", 7)  # many chunks, last one partial
    back = read_network(c, p)
    np.testing.assert_allclose(back.force, net.force, rtol=0, atol=0)
    np.testing.assert_array_equal(back.i, net.i)
    # an error in a late chunk still names the right line
    lines = c.read_text().splitlines()
    k = 9 + 500  # line number (1-based) of the 500th contact
    lines[k - 1] = lines[k - 1].replace(" ", " x", 1)
    c.write_text("\n".join(lines) + "\n")
    with pytest.raises(GrainmechError, match=rf"c\.dump:{k}: "):
        read_network(c, p)


def test_pieces_of_the_data_block_are_whole_lines_up_to_the_next_item():
    """``_windows`` cuts a block into pieces that end at line ends, together the block up to
    (not including) the first line starting with 'ITEM:', whatever the piece size, also for
    lines longer than a piece, a stop line at the very start of a piece and no final newline."""
    import io

    rng = np.random.default_rng(3)
    rows = [" ".join(["1.5"] * int(n)) for n in rng.integers(1, 40, 300)]
    block = "".join(r + "\n" for r in rows).encode()
    for text, want in ((block, block), (block + b"ITEM: TIMESTEP\n5\n1 2\n", block),
                       (block[:-1], block[:-1]), (b"ITEM: TIMESTEP\n", b"")):
        for size in (7, 64, 113, 4096, 1 << 20):
            pieces = list(blocks._windows(io.BytesIO(text), size, b"ITEM:"))
            assert b"".join(pieces) == want
            assert all(x.endswith(b"\n") for x in pieces[:-1]) and all(pieces)
            if size >= 200:  # a piece is at most its size plus the line carried over
                assert all(len(x) <= size + max(map(len, rows)) for x in pieces)
    # a stop line that starts exactly where a piece starts
    lines = [b"%d 2\n" % k for k in range(10)]
    text = b"".join(lines[:5]) + b"ITEM: X\n" + b"".join(lines[5:])
    for size in range(1, 40):
        assert b"".join(blocks._windows(io.BytesIO(text), size, b"ITEM:")) == b"".join(lines[:5])
    assert b"".join(blocks._windows(io.BytesIO(text), 16, None)) == text


def test_a_read_reports_its_progress_and_later_pieces_name_their_lines(tmp_path, monkeypatch, reader):
    """progress(done, total) rises to the file's size; with small pieces (the pyarrow path's
    worker threads) a non-integer id in a late piece is named with its line."""
    net = random_network(300, seed=2)
    c, p = tmp_path / "c.dump", tmp_path / "p.dump"
    write_liggghts(net, c, p)
    monkeypatch.setattr(blocks, "ARROW_WINDOW_MIN", 2000)
    monkeypatch.setattr(blocks, "CHUNK_LINES", 50)
    seen: list[tuple[int, int]] = []
    back = read_network(c, p, progress=lambda d, t: seen.append((d, t)))
    np.testing.assert_array_equal(back.force, net.force)
    size = c.stat().st_size
    assert len(seen) > 5 and all(t == size for _, t in seen)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen) and seen[-1][0] == size
    lines = c.read_text().splitlines()
    k = 9 + net.n_contacts - 3  # 1-based line of a contact near the end
    w = lines[k - 1].split()
    w[6] = "2.5"  # id1 of that contact
    lines[k - 1] = " ".join(w)
    c.write_text("\n".join(lines) + "\n")
    with pytest.raises(GrainmechError, match=rf"c\.dump:{k}: column '[^']+': value 2\.5 is not an integer id"):
        read_network(c, p)


def test_liggghts_keyword_order_is_fixed_by_the_compute(tmp_path):
    """`compute ... pair/gran/local force id pos` still writes pos, id, force (fixed order)."""
    c, p = tmp_path / "c.dump", tmp_path / "p.dump"
    _particles(p)
    _two_particle_dump(c, -50.0)
    net = read_liggghts(c, p, keywords=["force", "id", "pos"])
    np.testing.assert_allclose(net.force, [[50.0, 0, 0]])
    with pytest.raises(GrainmechError, match="unknown compute pair/gran/local keyword 'forces'"):
        read_liggghts(c, p, keywords=["forces", "id", "pos"])


def test_liggghts_file_written_by_hand_from_a_packing(tmp_path):
    """Dumps formatted here (not by grainmech's writer): triclinic LAMMPS bounds, centres
    remapped into the cell, force on the first particle, both particles listed."""
    net = random_network(120, cell=TRICLINIC, seed=21)
    H = TRICLINIC
    origin = np.array([-1.0, 2.0, 0.5])
    frac = np.mod(net.positions @ np.linalg.inv(H), 1.0)
    pos = origin + frac @ H  # wrapped centres
    xy, xz, yz = (float(v) for v in (H[1, 0], H[2, 0], H[2, 1]))
    xlo, ylo, zlo = (float(v) for v in origin)
    xhi, yhi, zhi = (float(v) for v in origin + np.diag(H))
    bounds = (f"ITEM: BOX BOUNDS xy xz yz pp pp pp\n"
              f"{xlo + min(0, xy, xz, xy + xz)!r} {xhi + max(0, xy, xz, xy + xz)!r} {xy!r}\n"
              f"{ylo + min(0, yz)!r} {yhi + max(0, yz)!r} {xz!r}\n{zlo!r} {zhi!r} {yz!r}\n")
    C = net.n_contacts
    with open(tmp_path / "c.dump", "w") as fh:
        fh.write(f"ITEM: TIMESTEP\n5\nITEM: NUMBER OF ENTRIES\n{C}\n{bounds}"
                 "ITEM: ENTRIES c_c[1] c_c[2] c_c[3] c_c[4] c_c[5] c_c[6] c_c[7] c_c[8] c_c[9] c_c[10] c_c[11] "
                 "c_c[12] c_c[13]\n")
        for c in range(C):
            a, b = net.i[c], net.j[c]
            f_on_a = -net.force[c]
            vals = [*pos[a], *pos[b], net.ids[a], net.ids[b], 0, *f_on_a, net.overlap[c]]
            fh.write(" ".join(repr(float(v)) for v in vals) + "\n")
    with open(tmp_path / "p.dump", "w") as fh:
        fh.write(f"ITEM: TIMESTEP\n5\nITEM: NUMBER OF ATOMS\n{net.n_particles}\n{bounds}"
                 "ITEM: ATOMS id type radius x y z vx\n")
        for k in range(net.n_particles):
            fh.write(f"{net.ids[k]} 1 " + " ".join(repr(float(v)) for v in (net.radii[k], *pos[k])) + " 0.0\n")
    back = read_network(tmp_path / "c.dump", tmp_path / "p.dump")
    np.testing.assert_allclose(back.box.cell, H, atol=1e-13)
    np.testing.assert_allclose(back.box.origin, origin, atol=1e-13)
    np.testing.assert_allclose(back.positions, pos, rtol=0, atol=0)
    np.testing.assert_allclose(back.force, net.force, rtol=0, atol=0)
    np.testing.assert_allclose(back.branch, net.branch, atol=1e-12)
    ref = _direct_stress(net.positions, net.i, net.j, net.force, H)
    np.testing.assert_allclose(network_stress(back).stress, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())
    # contact file alone (centres from its pos columns, box from its header)
    alone = read_network(tmp_path / "c.dump")
    np.testing.assert_allclose(network_stress(alone).stress, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())


def _network_arrays(net):
    return {k: getattr(net, k) for k in ("ids", "positions", "radii", "i", "j", "force", "branch",
                                         "overlap", "contact_point")}


@pytest.mark.parametrize("variant", ["plain", "trailing-space", "crlf", "two-snapshots", "exp-ids"])
def test_pyarrow_and_line_parser_give_identical_arrays(tmp_path, monkeypatch, variant, reader):
    """Bit-identical networks from both parsers for the forms LAMMPS/LIGGGHTS write
    ('%g ' columns with a trailing space, several snapshots in one file, ids as 1e+06),
    and the pyarrow path is really taken when pyarrow is installed."""
    if reader != "pyarrow":
        pytest.skip("compares the two parsers once")
    net = random_network(400, seed=4)
    net = type(net)(net.ids * 10000, net.positions, net.radii, net.box, net.i, net.j, net.force, net.branch,
                    net.overlap, net.contact_point, None, None, "t") if variant == "exp-ids" else net
    c, p = tmp_path / "c.dump", tmp_path / "p.dump"
    write_liggghts(net, c, p)
    text = c.read_text()
    if variant == "exp-ids":
        lines = text.splitlines()
        k = next(n for n, x in enumerate(lines) if x.startswith("ITEM: ENTRIES")) + 1
        for n in range(k, len(lines)):  # ids printed as %g does: 1e+06
            w = lines[n].split()
            w[6], w[7] = (f"{float(v):g}" for v in w[6:8])
            lines[n] = " ".join(w)
        text = "\n".join(lines) + "\n"
    if variant == "trailing-space":
        text = "".join(x + " \n" if x[:1].isdigit() or x[:1] == "-" else x + "\n" for x in text.splitlines())
    if variant == "crlf":
        text = text.replace("\n", "\r\n")
    if variant == "two-snapshots":
        text = text + text.replace("ITEM: TIMESTEP\n0", "ITEM: TIMESTEP\n100")
    c.write_bytes(text.encode())
    monkeypatch.setattr(blocks, "ARROW_WINDOW_MIN", 1500)  # ~100 pieces parsed on the worker threads
    calls = []
    real = blocks._read_block_arrow
    monkeypatch.setattr(blocks, "_read_block_arrow", lambda *a, **k: calls.append(real(*a, **k)) or calls[-1])
    fast = read_network(c, p)
    assert calls and all(x is not None for x in calls), "the pyarrow path was not taken"
    monkeypatch.setattr(blocks, "_arrow_csv", lambda: None)
    slow = read_network(c, p)
    for k, a in _network_arrays(fast).items():
        b = getattr(slow, k)
        assert (a is None) == (b is None), k
        if a is not None:
            assert a.dtype == b.dtype and np.array_equal(a, b), k
    np.testing.assert_array_equal(fast.force, net.force)  # sign: force by id1 on id2


def test_reader_threads_follow_pyarrows_cpu_count(reader):
    """The pieces are parsed on at most pyarrow's CPU count of threads (OMP_NUM_THREADS=1 in a
    sweep's worker processes gives 1), and on 1 to 8."""
    pa = pytest.importorskip("pyarrow")
    if reader != "pyarrow":
        pytest.skip("the pyarrow path only")
    before = pa.cpu_count()
    try:
        pa.set_cpu_count(1)
        assert blocks._reader_threads() == 1
        pa.set_cpu_count(64)
        assert 1 <= blocks._reader_threads() <= 8
    finally:
        pa.set_cpu_count(before)


@pytest.mark.parametrize("ext", ["npz", "csv"])
def test_contact_moments_round_trip_through_the_generic_tables(tmp_path, ext):
    """Rolling and twisting resistance: ``mx my mz`` (the moment by id1 on id2) written and read back
    bit for bit, and negated with the force under ``force_on = id1`` (the same convention)."""
    import dataclasses

    from grainmech.io.dem import read_table, write_table
    from grainmech.packing import load_packing

    net = load_packing("dense")
    m = np.random.default_rng(0).normal(size=(net.n_contacts, 3)) * 1e-9
    withm = dataclasses.replace(net, moment=m)
    write_table(withm, tmp_path / f"c.{ext}", tmp_path / f"p.{ext}")
    back = read_table(tmp_path / f"c.{ext}", tmp_path / f"p.{ext}")
    np.testing.assert_array_equal(back.moment, m)
    flipped = read_table(tmp_path / f"c.{ext}", tmp_path / f"p.{ext}", force_on="id1")
    np.testing.assert_array_equal(flipped.moment, -m)
    np.testing.assert_array_equal(flipped.force, -back.force)
    write_table(net, tmp_path / f"n.{ext}", tmp_path / f"q.{ext}")
    assert read_table(tmp_path / f"n.{ext}", tmp_path / f"q.{ext}").moment is None
