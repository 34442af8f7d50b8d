"""A stage function compiled once, out of line, in the step kernel.

A compile inlines a Warp function at each of its call sites, and NVRTC's time grows much
faster than the size of the one function it optimises (bench.inlining; docs/architecture.md,
"The step kernel"): the big stage functions are compiled once each, on their own
(``inline=False``, kept so by ptxas at the kernels' optimization level:
kernel_math.kernel_options). Warp passes a struct by value, and an out-of-line call would copy
the whole struct into local memory, so the out-of-line copy takes each struct argument (Model,
State, Control, Scratch) by reference: the address of the one-element array holding it (its
``<group>_address`` field, set by the Stepper), whose fields the compiler loads only where the
function reads them. The CPU's compile takes the same split: the same bits as every stage
inlined, a shorter first compile and no slower steps (README, "On a GPU").

The body itself is inlined into its out-of-line copy, its one call site (``WP_FORCEINLINE``):
left to the compiler, a body it kept apart received copies of the whole structs at every call
(the memmove of several KB; a box far from the ground, whose step calls the contact stages with
nothing near, 3.6 → 3.3 µs a step). Not the per-joint terms of the assembly
(``inline_body=False``): forced inline they made a Panda's step 4 % slower.

The two functions are written out as source (Warp compiles a function from its source text)
and registered with ``linecache`` so that Warp, ``inspect`` and bench.inlining read them as
any other.
"""

import ast
import linecache
import textwrap

import warp as wp

__all__ = ['apart']


def apart(t, f, inline_body: bool = True):
    """An inline function of ``f``'s signature (``f`` a Warp function of the types namespace
    ``t``) that calls ``f``'s out-of-line copy with the addresses of its struct arguments, with
    ``inline_body`` ``f`` itself inlined into that copy (see the module's docstring)."""
    groups = {getattr(t.structs, name): f'{name.lower()}_address' for name in vars(t.structs)}
    params = list(f.input_types.items())
    held = [name for name, kind in params if kind in groups]
    key = f.key.rsplit('__', 1)[-1]
    returns = ('return ' if any(isinstance(node, ast.Return) and node.value is not None
                                for node in ast.walk(f.adj.tree)) else '')
    kinds = {f'kind_{i}': kind for i, (name, kind) in enumerate(params)}
    outer = ', '.join(f'{name}: kind_{i}' for i, (name, kind) in enumerate(params))
    inner = ', '.join(f'{name}: wp.uint64' if name in held else f'{name}: kind_{i}'
                      for i, (name, kind) in enumerate(params))
    loaded = ', '.join(f'wp.array(ptr={name}, shape=(1,), dtype=kind_{i})[0]' if name in held
                       else name for i, (name, kind) in enumerate(params))
    passed = ', '.join(f'{name}.{groups[kind]}' if name in held else name
                       for name, kind in params)
    source = textwrap.dedent(f'''\
        def {key}_apart({inner}):
            {returns}f({loaded})

        def {key}({outer}):
            {returns}{key}_apart({passed})
        ''')
    filename = f'<out_of_line {f.key}>'
    linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
    scope = {'wp': wp, 'f': f, '__name__': f.func.__module__, **kinds}
    exec(compile(source, filename, 'exec'), scope)
    if inline_body:
        f.inline_hint = 'forceinline'
    scope[f'{key}_apart'] = wp.func(scope[f'{key}_apart'], inline=False,
                                    name=f'{f.key}_apart')
    wrapper = wp.func(scope[key], inline=True, name=f'{f.key}_by_reference')
    wrapper.__doc__ = f'``{key}`` out of line, its structs by reference ({__name__}).'
    return wrapper
