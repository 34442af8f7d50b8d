"""What a compiled CUDA kernel costs each thread, read from its cubin without a GPU.

A cubin (what ``wp.compile_aot_module(module, arch=90)`` writes, NVRTC only, no driver) is an
ELF file; its ``.nv.info`` section holds, per kernel, the registers per thread (attribute
``EIATTR_REGCOUNT``, 0x2f), the stack frame in local memory per thread (``EIATTR_FRAME_SIZE``,
0x11: register spills and local arrays such as 12×12 matrices) and, where the kernel calls
functions kept out of line, the stack its deepest chain of calls needs
(``EIATTR_MIN_STACK_SIZE``, 0x12: its frame and theirs); ``.text.<name>`` holds the machine
code of the kernel and of each such function. These numbers predict GPU occupancy (65536
registers per SM are shared by its resident threads), local-memory traffic and instruction
cache pressure before any device time is spent.
"""

import struct
from pathlib import Path
from typing import NamedTuple

__all__ = ['KernelResources', 'kernel_resources']

_REGCOUNT, _FRAME_SIZE, _MIN_STACK = 0x2F, 0x11, 0x12
# Record formats: SVAL (0x04) has a payload of ``size`` bytes after its 4-byte header; NVAL,
# BVAL and HVAL hold their value in the header itself.
_FORMAT_SVAL = 0x04


class KernelResources(NamedTuple):
    """Per-thread cost of one kernel: ``registers``, ``frame_bytes`` (local memory: its own
    frame and that of its deepest chain of out-of-line calls) and ``code_bytes`` (its machine
    code and that of every function its cubin keeps out of line)."""

    name: str
    registers: int
    frame_bytes: int
    code_bytes: int


def _sections(data: bytes) -> list:
    if data[:4] != b'\x7fELF' or data[4] != 2:
        raise ValueError('not a 64-bit ELF file (cubin)')
    offset, = struct.unpack_from('<Q', data, 0x28)
    entry, count, names = struct.unpack_from('<HHH', data, 0x3A)
    headers = [struct.unpack_from('<IIQQQQIIQQ', data, offset + i * entry) for i in range(count)]
    strings = headers[names][4]

    def name(at):
        start = strings + at
        return data[start:data.index(b'\0', start)].decode()

    return [(name(h[0]), h) for h in headers]


def _symbols(data: bytes, sections: list) -> list[str]:
    table = next(h for _, h in sections if h[1] == 2)            # SHT_SYMTAB
    strings = sections[table[6]][1][4]                           # its sh_link string table
    names = []
    for k in range(table[5] // 24):
        at, = struct.unpack_from('<I', data, table[4] + 24 * k)
        names.append(data[strings + at:data.index(b'\0', strings + at)].decode())
    return names


def kernel_resources(path) -> list[KernelResources]:
    """The kernels of cubin ``path`` with their registers, stack and code size."""
    data = Path(path).read_bytes()
    sections = _sections(data)
    symbols = _symbols(data, sections)
    code = {name[len('.text.'):]: h[5] for name, h in sections if name.startswith('.text.')}
    values = {_REGCOUNT: {}, _FRAME_SIZE: {}, _MIN_STACK: {}}
    for name, h in sections:
        if name != '.nv.info':
            continue
        at, end = h[4], h[4] + h[5]
        while at < end:
            fmt, attribute, size = struct.unpack_from('<BBH', data, at)
            if fmt == _FORMAT_SVAL:
                if attribute in values and size >= 8:
                    symbol, value = struct.unpack_from('<II', data, at + 4)
                    values[attribute][symbols[symbol]] = value
                at += 4 + size
            else:
                at += 4
    kernels = [name for name in values[_MIN_STACK] if name in code]
    functions = sum(size for name, size in code.items() if name not in kernels)
    return [KernelResources(name, values[_REGCOUNT][name],
                            values[_MIN_STACK].get(name, values[_FRAME_SIZE].get(name, 0)),
                            code[name] + functions)
            for name in kernels]
