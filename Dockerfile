# rftfem on the reference stack (Debian 12's FEniCSx packages, Open MPI).
#
#   docker build -t rftfem .
#   docker run --rm -v "$PWD":/work rftfem run scene.toml --out results/scene
#   docker run --rm -v "$PWD":/work --entrypoint mpirun rftfem -n 4 rftfem run scene.toml
#
# The image is set up by scripts/setup.sh, the same script CI runs, so every
# step taken here is exercised outside Docker too.
FROM debian:12

# Open MPI: allow root, and do not use cross-memory attach for shared-memory
# transfers (containers usually forbid it).
ENV DEBIAN_FRONTEND=noninteractive \
    OMPI_ALLOW_RUN_AS_ROOT=1 \
    OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMPI_MCA_btl_vader_single_copy_mechanism=none \
    PATH=/opt/rftfem/.venv/bin:$PATH

COPY . /opt/rftfem
RUN bash /opt/rftfem/scripts/setup.sh reference \
    && rm -rf /var/lib/apt/lists/* /root/.cache/pip

WORKDIR /work
ENTRYPOINT ["/opt/rftfem/.venv/bin/rftfem"]
