"""``bench reads`` writes the cost of a controller's reads and a contact read per scene."""

from affine_joint_sim.bench.reads import CONTROLLER_READS, Settings, run


def test_bench_reads_writes_its_table(tmp_path, capsys):
    run(tmp_path, ['cpu'], Settings(scenes=('quadruped',), settle=3, steps=3))
    text = (tmp_path / 'reads.md').read_text()
    assert '| quadruped | 12 |' in text
    for name in CONTROLLER_READS:
        assert f'{name} [µs]' in text
    header, row = (tmp_path / 'reads.csv').read_text().splitlines()
    values = dict(zip(header.split(','), row.split(',')))
    assert float(values['step_us']) > 0.0 and float(values['contacts_us']) > 0.0
    assert float(values['controller_us']) == sum(float(values[f'{n}_us'])
                                                 for n in CONTROLLER_READS)
    assert 'reads.md' in capsys.readouterr().out
