"""Build script of the pd_core ament_python package."""

from setuptools import find_packages, setup

PACKAGE = 'pd_core'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={PACKAGE: ['py.typed']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Pseudo-dynamic testing maintainers',
    maintainer_email='maintainers@pseudodynamic.dev',
    description=('The pure core of a pseudo-dynamic test (no ROS): integration schemes, '
                 'structural dynamics, the substructured model, and the run (step loop, '
                 'journal, bag, outputs), used by the integrator node and the tools.'),
    license='Apache-2.0',
)
