# fenics-coulomb in Docker: the same package list and install steps as container/run's rootfs.
#   docker build -t fenics-coulomb . && docker run --rm fenics-coulomb
# Debian trixie, pinned to a point release.
FROM debian:13.1

COPY container/packages.txt container/provision /tmp/
RUN sh /tmp/provision /tmp/packages.txt && rm /tmp/packages.txt /tmp/provision

ENV OMPI_ALLOW_RUN_AS_ROOT=1 \
    OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMPI_MCA_btl=self,sm \
    OMPI_MCA_pml=ob1 \
    PRTE_MCA_rmaps_default_mapping_policy=:oversubscribe \
    MPLBACKEND=Agg

WORKDIR /opt/fenics-coulomb
COPY . .
RUN python3 -m pip install --no-deps --no-build-isolation --break-system-packages . \
    && python3 -c "import fenics_coulomb, dolfinx; print(fenics_coulomb.__version__, dolfinx.__version__)" \
    && python -c "import fenics_coulomb"  # the usage line's `python` (python-is-python3) works too

CMD ["make", "demo"]
