# rftfem on the reference stack (Debian 12's FEniCSx packages, Open MPI),
# with pyvista for pictures and films, rendering off-screen (no display).
#
#   docker build -t rftfem .
#   docker run --rm -v "$PWD":/work rftfem run scene.toml --out results/scene
#   docker run --rm -v "$PWD":/work rftfem render results/scene --out results/scene/film.mp4
#   docker run --rm -v "$PWD":/work --entrypoint mpirun rftfem -n 2 rftfem run scene.toml
#
# mpirun may start more ranks than the machine has cores (oversubscription is
# allowed here, OMPI_MCA_rmaps_base_oversubscribe): handy for trying a
# decomposition on a laptop, slower than one rank per core.
#
# The image is set up by scripts/setup.sh, the same script CI runs, so every
# step taken here is exercised outside Docker too. The compiled forms of the
# shipped demo scenes are in the image (/opt/rftfem/cache): a demo run in a
# fresh container compiles nothing. Other scenes compile their forms on first
# use; mount a volume on /opt/rftfem/cache to keep them between containers.
FROM debian:12

# Open MPI: allow root, allow more ranks than cores, and do not use
# cross-memory attach for shared-memory transfers (containers usually forbid it).
# The JIT cache of forms lives in the image, whatever user runs it.
ENV DEBIAN_FRONTEND=noninteractive \
    OMPI_ALLOW_RUN_AS_ROOT=1 \
    OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMPI_MCA_rmaps_base_oversubscribe=1 \
    OMPI_MCA_btl_vader_single_copy_mechanism=none \
    XDG_CACHE_HOME=/opt/rftfem/cache \
    PATH=/opt/rftfem/.venv/bin:$PATH

COPY . /opt/rftfem
RUN bash /opt/rftfem/scripts/setup.sh reference \
    && rm -rf /var/lib/apt/lists/* /root/.cache/pip

# Fill the form cache: one short step of every shipped demo scene, serial and on
# two ranks, then a picture of one of them (checks off-screen rendering works).
RUN bash /opt/rftfem/scripts/warm_cache.sh /tmp/warm \
    && rm -rf /tmp/warm && chmod -R a+rwX /opt/rftfem/cache

WORKDIR /work
ENTRYPOINT ["/opt/rftfem/.venv/bin/rftfem"]
