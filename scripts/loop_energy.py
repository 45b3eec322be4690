#!/usr/bin/env python3
"""The bending energy ∫ (κ₁² + κ₂²) dA of a closed triangle mesh, estimated from the mesh
alone (docs/fair.md, "Is half reachable on spot at all?"): ∫ 4H² dA as Σ |L x|² / Aᵢ (L the
cotangent Laplacian, Aᵢ a third of the areas around vertex i) less twice the angle defects'
sum (∫ K dA). Vertices are welded by position first.

  scripts/loop_energy.py MESH.obj          the estimate for a tessellation (g1tess output)
  scripts/loop_energy.py MESH.obj N        the estimate after each of N Loop subdivisions

Needs numpy. Prints: triangles, ∫ 4H² dA, Σ angle defects, the estimate.
"""
import sys

import numpy as np

def load(p):
    V=[];F=[]
    with open(p) as f:
        for l in f:
            if l.startswith('v '): V.append([float(x) for x in l.split()[1:4]])
            elif l.startswith('f '):
                idx=[int(t.split('/')[0]) for t in l.split()[1:]]
                for k in range(1,len(idx)-1): F.append([idx[0],idx[k],idx[k+1]])
    V=np.array(V); F=np.array(F)-1
    # weld by position
    u,inv=np.unique(V,axis=0,return_inverse=True); F=inv.ravel()[F]
    F=F[(F[:,0]!=F[:,1])&(F[:,1]!=F[:,2])&(F[:,0]!=F[:,2])]
    return u,F
def willmore(V,F):
    n=len(V); E2=np.zeros(n); Lx=np.zeros((n,3)); A=np.zeros(n); ang=np.zeros(n)
    for k in range(3):
        i,j,l=F[:,k],F[:,(k+1)%3],F[:,(k+2)%3]
        # angle at i, opposite edge j-l
        a=V[j]-V[i]; b=V[l]-V[i]
        c=np.linalg.norm(np.cross(a,b),axis=1); d=(a*b).sum(1)
        cot=d/c; ang_i=np.arctan2(c,d)
        np.add.at(ang,i,ang_i)
        w=0.5*cot
        np.add.at(Lx,j,w[:,None]*(V[l]-V[j])); np.add.at(Lx,l,w[:,None]*(V[j]-V[l]))
        np.add.at(A,i,c/6.0)   # barycentric area: triangle area/3 = c/2/3
    H2=(Lx**2).sum(1)/A        # |Δx|^2 A = |Lx|^2/A  (Δx = Lx/A)
    defect=2*np.pi-ang
    return H2.sum(), defect.sum(), H2.sum()-2*defect.sum()
def loop(V,F):
    n=len(V)
    e=np.sort(np.concatenate([F[:,[0,1]],F[:,[1,2]],F[:,[2,0]]]),axis=1)
    ue,inv=np.unique(e,axis=0,return_inverse=True); inv=inv.ravel()
    m=len(F); opp=np.concatenate([F[:,2],F[:,0],F[:,1]])
    esum=np.zeros((len(ue),3)); np.add.at(esum,inv,V[opp])
    cnt=np.bincount(inv,minlength=len(ue)); assert (cnt==2).all(), "not closed manifold"
    EP=3/8*(V[ue[:,0]]+V[ue[:,1]])+1/8*esum
    nb=np.zeros((n,3)); val=np.zeros(n)
    np.add.at(nb,ue[:,0],V[ue[:,1]]); np.add.at(nb,ue[:,1],V[ue[:,0]]); np.add.at(val,ue[:,0],1); np.add.at(val,ue[:,1],1)
    beta=(5/8-(3/8+np.cos(2*np.pi/val)/4)**2)/val
    VP=(1-val*beta)[:,None]*V+beta[:,None]*nb
    NV=np.vstack([VP,EP]); ei=inv.reshape(3,m)+n
    a,b,c=F[:,0],F[:,1],F[:,2]; ab,bc,ca=ei[0],ei[1],ei[2]
    NF=np.vstack([np.stack([a,ab,ca],1),np.stack([ab,b,bc],1),np.stack([ca,bc,c],1),np.stack([ab,bc,ca],1)])
    return NV,NF
if __name__=='__main__':
    V,F=load(sys.argv[1])
    if len(sys.argv)>2:
        for lv in range(1,int(sys.argv[2])+1):
            V,F=loop(V,F); print('loop', lv, len(F), *map(float, willmore(V, F)))
    else:
        print(len(F), *map(float, willmore(V, F)))
