"""A split bag's ``metadata.yaml``, kept in memory and written without reading anything back.

``BagIndex`` holds what metadata.yaml says about the listed splits: each split's entry in
``relative_file_paths`` and ``files`` (as YAML text, dumped once when the split is listed),
the message count of every topic, and the bag's first and last message times. Listing a split
dumps only the split's own entries and the bag's small header (times, counts per topic), so the
YAML work per split does not grow with the number of splits; the earlier entries are joined as
text (a file grows by about 180 bytes per split). The text is what one ``yaml.safe_dump`` of
the whole metadata gives (keys sorted, as rosbags writes them), byte for byte (tested).
YAML goes through PyYAML's C emitter where PyYAML has libyaml, else through its Python one.
"""

import re
from pathlib import Path

import yaml

__all__ = ['BagIndex', 'dump_yaml', 'unlisted_bag', 'UNLISTED_BAG']

# why a directory that ``unlisted_bag`` finds is no bag to read
UNLISTED_BAG = ('split files but no metadata.yaml (a recording killed before it listed its '
                'first split?): not a bag rosbags can read')

_ROOT = 'rosbag2_bagfile_information'
_LISTS = ('files', 'relative_file_paths')      # the keys that grow by one entry per split


class _Dumper(getattr(yaml, 'CSafeDumper', yaml.SafeDumper)):
    """Safe dumper that writes a value shared by two keys twice, as rosbag2 does (no
    ``&id001`` anchors)."""

    def ignore_aliases(self, data):
        return True


def dump_yaml(data) -> str:
    """``yaml.safe_dump(data)`` (block style, keys sorted), with the C emitter when present."""
    return yaml.dump(data, Dumper=_Dumper)


def _nested(mapping: dict) -> str:
    """The lines ``mapping`` takes inside the root mapping of metadata.yaml."""
    return dump_yaml({_ROOT: mapping}).split('\n', 1)[1]


def _entry(key: str, value) -> str:
    """The lines of ``value`` as one entry of the list ``key`` inside the root mapping."""
    return dump_yaml({_ROOT: {key: [value]}}).split('\n', 2)[2]


class BagIndex:
    """What metadata.yaml lists: the closed splits of one bag, in order.

    Args:
        custom_data: the bag's ``custom_data`` strings (None or empty: none).
    """

    def __init__(self, custom_data: dict[str, str] | None = None):
        self.custom_data = dict(custom_data or {})
        self.names: list[str] = []          # file name of each listed split
        self.bytes = 0                      # size of the listed split files [B]
        self._constant: dict = {}           # the first split's fields that every split shares
        self._topics: list[dict] = []       # topic_metadata of every topic, in the bag's order
        self._counts: list[int] = []        # messages per topic, same order
        self._start: int | None = None      # first message of the bag [ns]
        self._end = 0                       # last message of the bag [ns]
        self._entries: dict[str, list[str]] = {key: [] for key in _LISTS}
        self._before: tuple | None = None   # what the last ``add`` changed, for ``retract``

    def add(self, info: dict, size: int) -> None:
        """List one closed split after the others.

        Args:
            info: the split's own ``rosbag2_bagfile_information`` (``SplitWriter.close``):
                one file, its message counts, start time [ns] and duration [ns].
            size: size of the split's file [B].
        """
        (entry,) = info['files']
        self._before = (list(self._counts), len(self._topics), self._start, self._end,
                        self.bytes)
        if not self.names:
            self._constant = {key: info[key] for key in ('version', 'storage_identifier',
                                                          'compression_format',
                                                          'compression_mode', 'ros_distro')}
            self._topics = [t['topic_metadata'] for t in info['topics_with_message_count']]
            self._counts = [0] * len(self._topics)
        for k, topic in enumerate(info['topics_with_message_count']):
            if k == len(self._topics):      # added to the bag after the first split
                self._topics.append(topic['topic_metadata'])
                self._counts.append(0)
            self._counts[k] += topic['message_count']
        if entry['message_count']:
            start = entry['starting_time']['nanoseconds_since_epoch']
            self._start = start if self._start is None else min(self._start, start)
            self._end = max(self._end, start + entry['duration']['nanoseconds'])
        self._entries['files'].append(_entry('files', entry))
        self._entries['relative_file_paths'].append(_entry('relative_file_paths', entry['path']))
        self.names.append(entry['path'])
        self.bytes += size

    def retract(self) -> None:
        """Undo the last ``add`` (its split could not be listed in metadata.yaml)."""
        self._counts, topics, self._start, self._end, self.bytes = self._before
        del self._topics[topics:]
        for entries in self._entries.values():
            entries.pop()
        self.names.pop()
        self._before = None

    def text(self) -> str:
        """metadata.yaml listing every split added so far (at least one)."""
        start = self._start if self._start is not None else 0
        header = {
            **self._constant,
            'custom_data': self.custom_data or None,
            'duration': {'nanoseconds': self._end - start},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': sum(self._counts),
            'topics_with_message_count': [
                {'topic_metadata': topic, 'message_count': count}
                for topic, count in zip(self._topics, self._counts)]}
        parts, run = [f'{_ROOT}:\n'], {}
        for key in sorted([*header, *_LISTS]):
            if key in self._entries:
                if run:
                    parts.append(_nested(run))
                    run = {}
                parts.append(f'  {key}:\n')
                parts.extend(self._entries[key])
            else:
                run[key] = header[key]
        if run:
            parts.append(_nested(run))
        return ''.join(parts)


def unlisted_bag(path: Path) -> bool:
    """A directory with split files named as its own (``NAME/NAME_0.mcap``) or the recorder's
    scratch splits (``.split_0/``) but no metadata.yaml: a recording killed before it listed
    its first split, or copied without its metadata (a directory of separate .mcap bags is not
    one)."""
    return path.is_dir() and not (path / 'metadata.yaml').is_file() and any(
        (p.suffix in ('.mcap', '.db3') and re.fullmatch(rf'{re.escape(path.name)}_\d+', p.stem))
        or (p.is_dir() and re.fullmatch(r'\.split_\d+', p.name)) for p in path.iterdir())
